(circle of radius 10 mm about X0 Y0 as one clockwise G2)
G21 G17 G90 G94 G64
G0 X0 Y0 Z5
G0 X10 Y0
G1 Z0 F600
G2 X10 Y0 I-10 J0 F1000
G0 Z5
M2
