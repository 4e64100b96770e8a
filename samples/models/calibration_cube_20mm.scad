// printtwin sample: 20 mm calibration cube, min corner at the origin.
// Expected by `printtwin check`: closed, 8000 mm3, no findings above info.
cube([20, 20, 20]);
