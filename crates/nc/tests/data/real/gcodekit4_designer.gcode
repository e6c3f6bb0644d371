; Generated G-code from Designer tool
; Tool diameter: 3.175mm
; Cut depth: -5.000mm
; Total path length: 985.841mm

G90         ; Absolute positioning
G21         ; Millimeter units
G17         ; XY plane
M3          ; Spindle on

N10 G00 X93.465 Y108.711 Z10.000
N20 G01 Z-5.000 F100
N30 G01 X207.699 Y108.711 F100
N40 G01 Z-5.000 F100
N50 G01 X207.699 Y344.031 F100
N60 G01 Z-5.000 F100
N70 G01 X93.465 Y344.031 F100
N80 G01 Z-5.000 F100
N90 G01 X93.465 Y108.711 F100
N100 G00 X0.000 Y0.000 Z10.000

M5          ; Spindle off
G00 Z10     ; Raise tool
G00 X0 Y0   ; Return to origin
M30         ; End program

; Generated G-code from Designer tool
; Tool diameter: 3.175mm
; Cut depth: -5.000mm
; Total path length: 1529.320mm

G90         ; Absolute positioning
G21         ; Millimeter units
G17         ; XY plane
M3          ; Spindle on

N10 G00 X243.688 Y130.184 Z10.000
N20 G01 Z-5.000 F100
N30 G01 X537.441 Y130.184 F100
N40 G01 Z-5.000 F100
N50 G01 X537.441 Y324.809 F100
N60 G01 Z-5.000 F100
N70 G01 X243.688 Y324.809 F100
N80 G01 Z-5.000 F100
N90 G01 X243.688 Y130.184 F100
N100 G00 X0.000 Y0.000 Z10.000

M5          ; Spindle off
G00 Z10     ; Raise tool
G00 X0 Y0   ; Return to origin
M30         ; End program

; Generated G-code from Designer tool
; Tool diameter: 3.175mm
; Cut depth: -5.000mm
; Total path length: 2555.580mm

G90         ; Absolute positioning
G21         ; Millimeter units
G17         ; XY plane
M3          ; Spindle on

N10 G00 X790.453 Y183.191 Z10.000
N20 G01 Z-5.000 F100
N30 G01 X1116.668 Y183.191 F100
N40 G01 Z-5.000 F100
N50 G01 X1116.668 Y323.363 F100
N60 G01 Z-5.000 F100
N70 G01 X790.453 Y323.363 F100
N80 G01 Z-5.000 F100
N90 G01 X790.453 Y183.191 F100
N100 G00 X0.000 Y0.000 Z10.000

M5          ; Spindle off
G00 Z10     ; Raise tool
G00 X0 Y0   ; Return to origin
M30         ; End program

; Generated G-code from Designer tool
; Tool diameter: 3.175mm
; Cut depth: -5.000mm
; Total path length: 2466.679mm

G90         ; Absolute positioning
G21         ; Millimeter units
G17         ; XY plane
M3          ; Spindle on

N10 G00 X588.848 Y419.750 Z10.000
N20 G01 Z-5.000 F100
N30 G01 X856.359 Y419.750 F100
N40 G01 Z-5.000 F100
N50 G01 X856.359 Y662.438 F100
N60 G01 Z-5.000 F100
N70 G01 X588.848 Y662.438 F100
N80 G01 Z-5.000 F100
N90 G01 X588.848 Y419.750 F100
N100 G00 X0.000 Y0.000 Z10.000

M5          ; Spindle off
G00 Z10     ; Raise tool
G00 X0 Y0   ; Return to origin
M30         ; End program

; Generated G-code from Designer tool
; Tool diameter: 3.175mm
; Cut depth: -5.000mm
; Total path length: 2962.055mm

G90         ; Absolute positioning
G21         ; Millimeter units
G17         ; XY plane
M3          ; Spindle on

N10 G00 X1089.254 Y510.457 Z10.000
N20 G01 Z-5.000 F100
N30 G01 X1249.133 Y510.457 F100
N40 G01 Z-5.000 F100
N50 G01 X1249.133 Y628.676 F100
N60 G01 Z-5.000 F100
N70 G01 X1089.254 Y628.676 F100
N80 G01 Z-5.000 F100
N90 G01 X1089.254 Y510.457 F100
N100 G00 X0.000 Y0.000 Z10.000

M5          ; Spindle off
G00 Z10     ; Raise tool
G00 X0 Y0   ; Return to origin
M30         ; End program

