(vcnc demo: a line, an arc and an exact quarter circle as a rational quadratic NURBS)
G21 G17 G90 G94 G64 P0.01
G0 X0 Y0 Z5
G1 Z0 F600
G1 X20 Y0 F3000
G3 X30 Y10 I0 J10
G1 X30 Y20
(quarter circle of radius 10 about X20 Y20, weights 1, sqrt2/2, 1)
G06.2 P3 K0 X30 Y20 Z0 R1 F3000
K0 X30 Y30 R0.70710678
K0 X20 Y30 R1
K1
K1
K1
G1 X0 Y30
G0 Z5
M2
