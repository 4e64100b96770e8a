; scenario: feature/width/object tags of PrusaSlicer, Cura and Orca
M104 S200
M109 S200
G28
M83
G1 X10 Y10 Z0.2 F3000
;TYPE:External perimeter
;WIDTH:0.45
;HEIGHT:0.2
; printing object cube.stl id:0 copy 0
G1 X20 E0.5 F1200
; stop printing object cube.stl id:0 copy 0
;TYPE:WALL-INNER
;MESH:part_b.stl
G1 X30 E0.5
; FEATURE: Sparse infill
; LINE_WIDTH: 0.42
EXCLUDE_OBJECT_START NAME=third
G1 X40 E0.5
EXCLUDE_OBJECT_END NAME=third
M486 S7
;TYPE:Support material
G1 X50 E0.5
M486 S-1
G1 Z0.4
;TYPE:Skirt/Brim
G1 X60 E0.5
M600 ; unknown: filament change
M600
G29 ; unknown: bed probing
