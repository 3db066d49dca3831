"""rigid_env: Gymnasium environments on a NumPy rigid-body simulator."""

__version__ = "0.1.0"
