"""The papers' case studies, the demo and their timing helpers.

Dwarshuis et al. (2020): the cross flexure (`demo`), the EOB limits (`eob`), the four-bar
(`fourbar`) and the spatial manipulator (`manipulator`); Cammarata et al. (2022): the MEMS gripper
(`gripper`). They sit on top of the library: the command line, the examples and the benchmarks
import them; ``import flexmb`` does not (tests/test_layout.py checks it).
"""
