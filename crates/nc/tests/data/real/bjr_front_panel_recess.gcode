


G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z0.0  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.05  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.1  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.15000000000000002  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.2  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.25  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.3  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.35  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.39999999999999997  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.44999999999999996  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.49999999999999994  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program




G90	; disable incremental moves
G21	; metric
G61	; exact path mode
M3	; start spindle
G04 P3	; wait for 3 seconds
;G0 X0 Y0 Z4.0 F800
G90
G1 Z4.0  F100
G90
G1 X0  F1800
G90
G1 Y0  F1800
G90
G1 Z4.0  F100
G90
G1 X20 Y51 F1800
G90
G1 Z-0.5  F100
G90
G1 X58 Y51 F25
G90
G1 X58 Y42.5 F25
G90
G1 X20 Y42.5 F25
G90
G1 X20 Y51 F25

G0 Z4.0     ; Z now safe
G28  X         ; home X
;  M1	; end program



M1    ;End program
