(Exported by FreeCAD)
(written for the test in the style of FreeCAD's grbl post; dialect grbl)
(Begin preamble)
G17 G90
G21
(Begin operation: Profile)
(Path: Profile)
G0 Z5.000
G0 X10.000 Y0.000
G1 Z-1.000 F300.000
G2 X0.000 Y10.000 Z-1.000 I-10.000 J0.000 K0.000 F600.000
G2 X-10.000 Y0.000 Z-1.000 I0.000 J-10.000 K0.000 F600.000
G1 X-10.000 Y-5.000 Z-1.000 F600.000
G0 Z5.000
(Finish operation: Profile)
(Begin postamble)
M5
G17 G90
M2
