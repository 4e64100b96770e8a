; scenario: a move past the X travel after homing is clamped by the software endstops
M104 S200
M109 S200
G28
G90
M83
G1 Z0.2 F600
G1 X10 Y10 F3000
G1 X250 Y10 E5 F1200 ; line 9: beyond X 235 -> out_of_bounds, clamped
G1 X10 Y10 F3000
