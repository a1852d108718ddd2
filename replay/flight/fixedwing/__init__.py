"""The fixed wing: parameters and presets, the 12-state model (numpy reference and compiled
kernels), trim, the autopilot (gain design and the inner loop), and its flight stack."""
