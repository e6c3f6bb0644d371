%
(boss_contour: after S4's experiment. R5 ball-end mill, tip z = 0)
(path A-F: line A-B in air, arc R20.1705 through C, D, E, line F'-F in air)
(0.2 mm stock steps at C and E; light cut around D)
O0001
G21 G17 G90 G54 G94
T1 M6
S6000 M3
G0 X-30. Y-20.1705 Z20.
G0 Z5.
G1 Z0. F1500
(A -> B)
G1 X0. Y-20.1705
(B -> C)
G3 X14.2627 Y-14.2627 I0. J20.1705
(C -> D)
G3 X20.1705 Y0. I-14.2627 J14.2627
(D -> E)
G3 X14.2627 Y14.2627 I-20.1705 J0.
(E -> F')
G3 X0. Y20.1705 I-14.2627 J-14.2627
(F' -> F)
G1 X-30.
G0 Z20.
M5
M30
%
