"""Planar constant-stiffness flexures (Cammarata et al. 2022): the closed-form wrench and tangent,
the links-only problem and its builder."""
