"""Camera calibration: the ChArUco hand-eye core (calibration) and the calibrate_camera tool."""
