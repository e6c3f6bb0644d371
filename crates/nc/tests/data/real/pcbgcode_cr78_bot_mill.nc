(/Applications/pcbgcode.repo/pcb-gcode.ulp)
(Copyright 2005 - 2012 by John Johnson)
(See readme.txt for licensing terms.)
(This file generated from the board:)
(.../CR78-Controller/eagle/midi_to_cv.brd)
(Current profile is .../pcbgcode.repo/profiles/mach.pp  )
(This file generated 6/8/16 11:04 PM)
(Settings from pcb-machine.h)
(spindle on time = 0.0000)
(spindle speed = 15000.0000)
(milling depth = -0.0700)
(tool change at 0.0000  0.0000  1.5000  )
(feed rate xy = F10    )
(feed rate z  = F5     )
(Z Axis Settings)
(  High     Up        Down     Drill)
(0.2500  	0.0500  	-0.0035 	-0.0750 )
(Settings from pcb-defaults.h)
(isolate min = 0.0050)
(isolate max = 0.0200)
(isolate step = 0.0010)
(Generated bottom outlines, bottom drill, )
(Unit of measure: inch)
(Inch Mode)
G20
(Absolute Coordinates)
G90
S15000
G00 Z0.2500  
G00 X0.0000  Y0.0000  
M03
G04 P0.000000
G00 Z0.0500  
G01 Z-0.0700 F5     
G01 X-0.0400 Y-0.0300 F10    
G01 X-3.2900 Y-0.0300 
G01 X-3.3200 Y0.0000  
G01 X-3.3200 Y3.0000  
G01 X-3.2500 Y3.0500  
G01 X-0.0500 Y3.0500  
G01 X0.0000  Y3.0000  
G01 X0.0000  Y0.0000  
G00 Z0.0500  
G00 X-0.2200 Y1.3400  
G01 Z-0.0700 F5     
G01 X-0.2700 Y1.3400  F10    
G01 X-0.2700 Y1.3900  
G01 X-0.2400 Y1.3900  
G00 Z0.0500  
G00 X-0.2200 Y1.3900  
G01 Z-0.0700 F5     
G01 X-0.2200 Y1.3400  F10    
G00 Z0.0500  
G00 X-0.1800 Y2.8800  
G01 Z-0.0700 F5     
G01 X-0.1800 Y2.9300  F10    
G01 X-0.1500 Y2.9300  
G00 Z0.0500  
G00 X-0.1300 Y2.9300  
G01 Z-0.0700 F5     
G01 X-0.1300 Y2.8800  F10    
G01 X-0.1800 Y2.8800  
G00 Z0.0500  
G00 X-2.5500 Y2.6100  
G01 Z-0.0700 F5     
G01 X-2.5500 Y2.5600  F10    
G01 X-2.6000 Y2.5600  
G01 X-2.6000 Y2.6100  
G01 X-2.5700 Y2.6100  
G00 Z0.0500  
G00 X-3.1400 Y1.9900  
G01 Z-0.0700 F5     
G01 X-3.1400 Y1.9400  F10    
G01 X-3.1900 Y1.9400  
G01 X-3.1900 Y1.9900  
G01 X-3.1600 Y1.9900  
G00 Z0.0500  
G00 X-2.4400 Y0.1400  
G01 Z-0.0700 F5     
G01 X-2.4100 Y0.1400  F10    
G00 Z0.0500  
G00 X-2.3900 Y0.1400  
G01 Z-0.0700 F5     
G01 X-2.3900 Y0.0900  F10    
G01 X-2.4400 Y0.0900  
G01 X-2.4400 Y0.1400  
G00 Z0.2500  
M05
M02
