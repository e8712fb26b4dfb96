(A test curve like paper 000's: a planar cubic NURBS, length 0.0890 mm,)
(control-polygon length 0.1570 mm, tightest radius of curvature 1.00 um.)
(F60 at a 1 ms period is a 1 um step: try  vcnc interp programs/curve000.nc --step-um 1)
G21 G17 G90 G94
G0 X0 Y0 Z0
G06.2 P4 K0 X0 Y0 Z0 R1 F60
K0 X0.0198 Y0.0217 R1
K0 X0.0405 Y0.0049 R1
K0 X0.0384 Y0.0244 R1
K0.2 X0.0553 Y0.0012 R1
K0.4 X0.0576 Y0.0184 R1
K0.6 X0.0702 Y0.0002 R1
K0.8 X0.0687 Y0.0133 R1
K1
K1
K1
K1
M2
