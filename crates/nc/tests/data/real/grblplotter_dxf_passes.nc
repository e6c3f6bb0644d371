( DXF import by GRBL-Plotter )
( Source: C:\Users\Sven_User\GMX Mediacenter\Aktuell\GRBL\__Test_Data\DXF_crc2.dxf )
( G-Code lines: 28 )
( Pen Down/Up : 6 times )
( Path length : 0.0 units )
( Duration ca.: 0.1 min. )
( Conv. time  : 00:00:00.0026000 )
M3 S1000 (Start spindle - Option Z-Axis)
G00 Z2.000
(<figure 1> DXFcolor=#3 )
(<pass 1 -0.900 / -1.000 >)
G00 X0.000 Y-2.000
G01 Z-0.900 F500
G01 X10.000 Y-2.000 F2000
G03 X11.414 Y1.414 I0.000 J2.000
G01 X11.000 Y1.828
G01 X11.000 Y10.000
G00 Z2.000
(</pass 1 >)
(<pass 2 -1.000 / -1.000 >)
G00 X0.000 Y-2.000
G01 Z-1.000 F500
G01 X10.000 Y-2.000 F2000
G03 X11.414 Y1.414 I0.000 J2.000
G01 X11.000 Y1.828
G01 X11.000 Y10.000
G00 Z2.000
(</pass 2 >)
(</figure 1>)
(<figure 2> DXFcolor=#1 )
(<pass 1 -0.900 / -1.000 >)
G00 X15.000 Y-2.000
G01 Z-0.900 F500
G01 X25.000 Y-2.000 F2000
G03 X26.789 Y0.894 I0.000 J2.000
G03 X26.000 Y1.991 I-3.789 J-1.894
G01 X26.000 Y10.000
G00 Z2.000
(</pass 1 >)
(<pass 2 -1.000 / -1.000 >)
G00 X15.000 Y-2.000
G01 Z-1.000 F500
G01 X25.000 Y-2.000 F2000
G03 X26.789 Y0.894 I0.000 J2.000
G03 X26.000 Y1.991 I-3.789 J-1.894
G01 X26.000 Y10.000
G00 Z2.000
(</pass 2 >)
(</figure 2>)
M05 (Stop spindle - Option Z-Axis)
G0X0Y0 (Setup - GCode-Footer)
M30 (Program end)
