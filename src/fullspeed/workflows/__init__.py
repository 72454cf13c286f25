"""Work built on runs: the durable parallel journal and the sweeps on it,
the cross-saturation calibration, self-commissioning (identify), the export
of a drive's configuration as C, and the loss-of-lock campaign."""
