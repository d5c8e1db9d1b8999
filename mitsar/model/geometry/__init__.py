"""Platform and antenna geometry: trajectories, attitude, boresight (paper eq. 3), beam pattern."""
