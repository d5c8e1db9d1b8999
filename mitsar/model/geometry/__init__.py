"""Platform and antenna geometry: trajectories, attitude and boresight (paper eq. 3), beam pattern."""
