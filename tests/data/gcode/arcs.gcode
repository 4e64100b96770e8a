; scenario: arcs in the I/J and R forms (Marlin plan_arc segmentation)
M104 S200
M109 S200
G28
G90
M83
G1 X100 Y100 Z0.2 F3000
G2 X120 Y100 I10 J0 E1 F1200 ; half circle, radius 10, clockwise over the top
G3 X100 Y100 R10 E1 ; back, counter-clockwise, radius form
G2 X100 Y100 I10 J0 ; full circle (same start and end)
