; scenario: moves before G28 and extrusion with a cold hotend
G90
M83
G1 X20 Y20 Z5 F3000 ; line 4: move_before_homing
G28
G1 Z0.2 F600
G1 X50 Y20 E2 F1200 ; line 7: cold_extrusion (the firmware drops the E part)
M104 S210
M109 S210
G1 X80 Y20 E2 F1200 ; extrudes
