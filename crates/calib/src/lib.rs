//! Camera calibration: checkerboard corners, Zhang's method refined by Levenberg-Marquardt,
//! OpenCV-compatible YAML.
