/*
  grbl.h - the harness's stand-in for grbl 1.1's grbl.h: only what planner.c and the
  two nuts_bolts.c functions it calls need (settings, system state, the stepper's
  interface), no AVR. Part of dexcut's scripts/grbl_reference (GPL-3.0-or-later like
  the grbl files it is compiled with; see grbl/COPYING).
*/
#ifndef grbl_h
#define grbl_h

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* grbl/config.h's defaults that planner.c and stepper.c read. */
#define MINIMUM_JUNCTION_SPEED 0.0 /* (mm/min) */
#define MINIMUM_FEED_RATE 1.0      /* (mm/min) */
#define ACCELERATION_TICKS_PER_SECOND 100
#define F_CPU 16000000UL

#include "grbl/nuts_bolts.h"
#include "grbl/planner.h"

/* settings.h: only the fields the planner reads; acceleration in mm/min^2 as grbl
   stores it ($120 * 3600). */
typedef struct {
  float steps_per_mm[N_AXIS];
  float max_rate[N_AXIS];
  float acceleration[N_AXIS];
  float junction_deviation;
  float arc_tolerance;
} settings_t;
extern settings_t settings;

/* system.h: overrides at 100 %, the machine position in steps. */
typedef struct {
  uint8_t f_override;
  uint8_t r_override;
} system_t;
extern system_t sys;
extern int32_t sys_position[N_AXIS];

/* settings.c / stepper.c interface used by planner.c. */
#define get_direction_pin_mask(idx) ((uint8_t)(1 << (idx)))
void st_update_plan_block_parameters(void);

float convert_delta_vector_to_unit_vector(float *vector);
float limit_value_by_axis_maximum(float *max_value, float *unit_vec);

#endif
