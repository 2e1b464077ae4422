"""Joint database: trained kinematic data of standard joints (Dwarshuis et al. 2020, Secs. 2.1, 3.1)."""

from .store import (FORMAT, FORMAT_VERSION, JointData, Polynomial, data_path, design_file_name, file_name, load,
                    locate, save, search_path, shipped, source, user_path, write)
from .training import TRAINING, TRAINING_SCHEMA, TrainingRun, simulate, train, training_settings, verify

__all__ = ["FORMAT", "FORMAT_VERSION", "JointData", "Polynomial", "TrainingRun", "data_path", "design_file_name",
           "file_name", "load", "locate", "save", "search_path", "shipped", "simulate", "source", "train",
           "training_settings", "user_path", "verify", "write", "TRAINING", "TRAINING_SCHEMA"]
