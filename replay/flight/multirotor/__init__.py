"""The multirotor: parameters and the ``quadrotor`` preset, the 16-state model (numpy reference
and compiled kernels) and its flight stack (cascaded position / attitude controller)."""
