"""Finite-element core: co-rotational beam elements, the model they form, sparse assembly."""
