( Made using CamBam - http://www.cambam.co.uk )
( written for the test in the style of CamBam's Mach3 post; dialect mach3 )
( T1 : 6.0 )
G21 G90 G91.1 G64 G40
G0 Z3.0
( T1 : 6.0 )
T1 M6
( Profile1 )
G17
M3 S12000
G0 X0.0 Y-3.0
G0 Z1.0
G1 F300.0 Z-1.0
G1 F1000.0 X30.0
G3 X33.0 Y0.0 I0.0 J3.0
G1 Y20.0
G3 X30.0 Y23.0 I-3.0 J0.0
G1 X0.0
G0 Z3.0
M5
M30
