"""terrapath: terrain-aware path planning and 6-DOF replay for fixed-wing and multirotor UAVs."""

__version__ = "0.1.0"
