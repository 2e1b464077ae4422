"""Tutorial: the MEMS gripper of Cammarata et al. (2022) with curved-beam flexures (mm, uN).

Four rigid bodies joined by four circular curved beams: a force on body 2 closes the clamp on
body 3. flexmb solves it three ways: the paper's closed-form constant-stiffness models (linear
and partial non-linear wrench, `method="newton"`, Eqs. 18-28) and its own fully non-linear
finite-element model of the arcs (`method="conventional"`). Printed: the closing force of each
(end-effector x = 0) beside the values the test suite holds, and the end-effector's path.
Run: python examples/tutorial_gripper.py [--quick]   (the same numbers either way)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb.studies import example_arguments

END_EFFECTOR = ("body3", "end_effector")     # the named point on body 3 (link, point)


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Closing forces and a sweep of the end effector; nothing is written, ``quick`` changes nothing."""
    # --8<-- [start:closing]
    closing = {}
    for label, model, method, options in (("linear (closed form)", "linear", "newton", {}),
                                          ("partial non-linear", "partial-nonlinear", "newton", {}),
                                          ("FE, 16 el./arc", "partial-nonlinear", "conventional", {"tol": 1e-5})):
        gripper = flexmb.models.gripper("silicon", model=model)            # mm, uN; the force on body 2
        closing[label] = flexmb.find_actuation(gripper, END_EFFECTOR, np.arange(0.0, 200.0, 10.0),
                                               method=method, **options)    # [uN] where x = 0
    # --8<-- [end:closing]
    print(f"{'model':22} {'closing force [uN]':>19}")
    for label, force in closing.items():
        print(f"{label:22} {force:19.3f}")
    # --8<-- [start:sweep]
    gripper = flexmb.models.gripper("silicon", model="partial-nonlinear")
    forces = np.array([-60.0, -30.0, 0.0, 30.0, 60.0])                      # [uN]
    closed_form = flexmb.sweep(gripper, forces, method="newton", progress=False)
    fe = flexmb.sweep(gripper, forces, method="conventional", tol=1e-5, progress=False)
    # --8<-- [end:sweep]
    print(f"{'F_2y [uN]':>9} {'end effector x, y [um]: closed form':>36} {'FE':>20}")
    for f, s, r in zip(forces, closed_form, fe):
        p, q = s.point(*END_EFFECTOR) * 1e3, r.point(*END_EFFECTOR) * 1e3
        print(f"{f:9.1f} {p[0]:26.2f}, {p[1]:9.2f} {q[0]:10.2f}, {q[1]:9.2f}")
    return {"closing": closing, "closed_form": closed_form, "fe": fe}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
