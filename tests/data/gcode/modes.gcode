; scenario: G91/G90, G92, M82/M83, G20/G21, M221, M200
M104 S200
M109 S200
G28
G90
M82
G92 E0
G1 X10 Y10 Z0.2 F3000
G1 X20 E1 F1200 ; absolute E: +1
G1 X30 E1.5 ; +0.5
G92 E10
G1 X40 E11 ; +1
M83
G1 X50 E1 ; relative: +1
G91
G1 X5 Y5 ; relative XYZ -> 55, 15
G1 E0.5 ; G91 makes E relative too: +0.5 (unretract, E only)
G90 ; also makes E absolute again (Marlin)
G92 X0 Y0 E0
G1 X1 Y1 E0.5 ; logical 1,1 = machine 56,16: +0.5
M221 S50
G1 X2 Y1 E1.5 ; +1 at flow 50 %: +0.5
M221 S100
M83
G20
G1 X2.5 E0.01 ; inches: logical X 63.5 mm, +0.254 mm
G21
M200 D1.75
G1 X70 E2.405282 ; volumetric: 2.405282 mm3 = 1 mm of 1.75 mm filament
M200 D0
