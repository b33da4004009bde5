"""3-D serial chains: the model, robot files (TOML DH tables, URDF), derivation, reference."""

from .dh_file import chain_from_table, load_robot_file
from .loader import load_robot
from .model import Chain, Joint, Transform, dh_joint
from .urdf import load_urdf

__all__ = ["Chain", "Joint", "Transform", "chain_from_table", "dh_joint", "load_robot", "load_robot_file", "load_urdf"]
