/*
  harness.c - grbl 1.1's planner (grbl/planner.c, verbatim) run over a list of line
  blocks, with the stepper's execution of each block (a port of st_prep_buffer()'s
  velocity profile and 10 ms segment arithmetic, stepper.c) in place of the AVR.
  Part of dexcut's scripts/grbl_reference; GPL-3.0-or-later like the grbl files it is
  compiled with (grbl/COPYING). See README.md.

  Usage: grbl_harness SETTINGS.txt < blocks.txt > planned.txt
  SETTINGS.txt: a grbl `$$` dump ($11, $12, $100-$102, $110-$112, $120-$122 read).
  blocks.txt (written by `cargo run -p schedule --example grbl_blocks`):
    start X Y Z          the machine position, mm (before the first block)
    F X Y Z FEED K       a feed line to X Y Z (mm) at FEED mm/min; K its index
    R X Y Z K            a rapid to X Y Z
    S DWELL K            the buffer runs empty (a dwell or a spindle/tool change), then
                         DWELL seconds at rest
  Streaming as a fast sender streams (mc_line): before each block, while
  plan_check_full_buffer(), the tail block is executed (its trapezoid, from its planned
  entry speed to plan_get_exec_block_exit_speed_sqr()) and discarded
  (plan_discard_current_block); at a sync and at the end the buffer is drained.
  Output, one line per executed block:
    B K ENTRY EXIT NOMINAL MAX_ENTRY MM ACCEL TIME
  (speeds mm/min, MM the block's length, ACCEL mm/s^2, TIME s: its segments' times as
  the step ISR runs them, CPU cycles per step rounded up as stepper.c rounds them, AMASS
  on), `S K DWELL` per sync, `E K` per block grbl drops (no whole step), and
  `total TIME_S PROFILE_S` at the end (both with the dwells; PROFILE_S: the sum of the
  segments' planned times dt, which near the end of a deceleration to rest can hold a
  segment of seconds for the last fraction of a step, run by the ISR as one slow step).
*/
#include <stdio.h>
#include "grbl.h"

settings_t settings;
system_t sys;
int32_t sys_position[N_AXIS];

void st_update_plan_block_parameters(void) {}

/* stepper.c's constants. */
#define DT_SEGMENT (1.0/(ACCELERATION_TICKS_PER_SECOND*60.0)) /* min/segment */
#define REQ_MM_INCREMENT_SCALAR 1.25
#define RAMP_ACCEL 0
#define RAMP_CRUISE 1
#define RAMP_DECEL 2
#define MAX_AMASS_LEVEL 3
#define AMASS_LEVEL1 (F_CPU/8000)
#define AMASS_LEVEL2 (F_CPU/4000)
#define AMASS_LEVEL3 (F_CPU/2000)

/* stepper.c's st_prep_t, the fields the normal (no hold, no override) path uses. */
static struct {
  float steps_remaining;
  float step_per_mm;
  float req_mm_increment;
  float dt_remainder;
  uint8_t ramp_type;
  float mm_complete;
  float current_speed;
  float maximum_speed;
  float exit_speed;
  float accelerate_until;
  float decelerate_after;
} prep;

static double profile_s; /* the segments' planned times (dt), s */

/* st_prep_buffer() for one whole planner block (the tail), normal operation: the
   profile from the block's entry speed to the planner's exit speed, then segments of
   DT_SEGMENT until the block ends. Returns the time the step ISR takes over its
   segments, s: each segment's steps at its CPU cycles per step, rounded up as stepper.c
   rounds them (AMASS on, at most 0xffff cycles a tick). */
static double execute_block(plan_block_t *pl_block)
{
  double block_min = 0.0;
  double block_s = 0.0;
  prep.steps_remaining = (float)pl_block->step_event_count;
  prep.step_per_mm = prep.steps_remaining/pl_block->millimeters;
  prep.req_mm_increment = REQ_MM_INCREMENT_SCALAR/prep.step_per_mm;
  prep.dt_remainder = 0.0;
  prep.current_speed = sqrt(pl_block->entry_speed_sqr);

  prep.mm_complete = 0.0;
  float inv_2_accel = 0.5/pl_block->acceleration;
  prep.ramp_type = RAMP_ACCEL;
  prep.accelerate_until = pl_block->millimeters;
  float exit_speed_sqr;
  float nominal_speed;
  exit_speed_sqr = plan_get_exec_block_exit_speed_sqr();
  prep.exit_speed = sqrt(exit_speed_sqr);
  nominal_speed = plan_compute_profile_nominal_speed(pl_block);
  float nominal_speed_sqr = nominal_speed*nominal_speed;
  float intersect_distance =
    0.5*(pl_block->millimeters+inv_2_accel*(pl_block->entry_speed_sqr-exit_speed_sqr));
  if (pl_block->entry_speed_sqr > nominal_speed_sqr) {
    fprintf(stderr, "entry above nominal: only under an override\n");
    exit(2);
  } else if (intersect_distance > 0.0) {
    if (intersect_distance < pl_block->millimeters) {
      prep.decelerate_after = inv_2_accel*(nominal_speed_sqr-exit_speed_sqr);
      if (prep.decelerate_after < intersect_distance) {
        prep.maximum_speed = nominal_speed;
        if (pl_block->entry_speed_sqr == nominal_speed_sqr) {
          prep.ramp_type = RAMP_CRUISE;
        } else {
          prep.accelerate_until -= inv_2_accel*(nominal_speed_sqr-pl_block->entry_speed_sqr);
        }
      } else {
        prep.accelerate_until = intersect_distance;
        prep.decelerate_after = intersect_distance;
        prep.maximum_speed = sqrt(2.0*pl_block->acceleration*intersect_distance+exit_speed_sqr);
      }
    } else {
      prep.ramp_type = RAMP_DECEL;
    }
  } else {
    prep.accelerate_until = 0.0;
    prep.maximum_speed = prep.exit_speed;
  }

  for (;;) {
    float dt_max = DT_SEGMENT;
    float dt = 0.0;
    float time_var = dt_max;
    float mm_var;
    float speed_var;
    float mm_remaining = pl_block->millimeters;
    float minimum_mm = mm_remaining-prep.req_mm_increment;
    if (minimum_mm < 0.0) { minimum_mm = 0.0; }
    do {
      switch (prep.ramp_type) {
        case RAMP_ACCEL:
          speed_var = pl_block->acceleration*time_var;
          mm_remaining -= time_var*(prep.current_speed + 0.5*speed_var);
          if (mm_remaining < prep.accelerate_until) {
            mm_remaining = prep.accelerate_until;
            time_var = 2.0*(pl_block->millimeters-mm_remaining)/(prep.current_speed+prep.maximum_speed);
            if (mm_remaining == prep.decelerate_after) { prep.ramp_type = RAMP_DECEL; }
            else { prep.ramp_type = RAMP_CRUISE; }
            prep.current_speed = prep.maximum_speed;
          } else {
            prep.current_speed += speed_var;
          }
          break;
        case RAMP_CRUISE:
          mm_var = mm_remaining - prep.maximum_speed*time_var;
          if (mm_var < prep.decelerate_after) {
            time_var = (mm_remaining - prep.decelerate_after)/prep.maximum_speed;
            mm_remaining = prep.decelerate_after;
            prep.ramp_type = RAMP_DECEL;
          } else {
            mm_remaining = mm_var;
          }
          break;
        default:
          speed_var = pl_block->acceleration*time_var;
          if (prep.current_speed > speed_var) {
            mm_var = mm_remaining - time_var*(prep.current_speed - 0.5*speed_var);
            if (mm_var > prep.mm_complete) {
              mm_remaining = mm_var;
              prep.current_speed -= speed_var;
              break;
            }
          }
          time_var = 2.0*(mm_remaining-prep.mm_complete)/(prep.current_speed+prep.exit_speed);
          mm_remaining = prep.mm_complete;
          prep.current_speed = prep.exit_speed;
      }
      dt += time_var;
      if (dt < dt_max) { time_var = dt_max - dt; }
      else {
        if (mm_remaining > minimum_mm) {
          dt_max += DT_SEGMENT;
          time_var = dt_max - dt;
        } else {
          break;
        }
      }
    } while (mm_remaining > prep.mm_complete);
    block_min += dt;

    float step_dist_remaining = prep.step_per_mm*mm_remaining;
    float n_steps_remaining = ceil(step_dist_remaining);
    float last_n_steps_remaining = ceil(prep.steps_remaining);
    uint32_t n_step = (uint32_t)(last_n_steps_remaining-n_steps_remaining);
    dt += prep.dt_remainder;
    float inv_rate = dt/(last_n_steps_remaining - step_dist_remaining);
    uint32_t cycles = ceil( (TICKS_PER_MICROSECOND*1000000*60)*inv_rate );
    uint8_t amass_level = 0;
    if (cycles >= AMASS_LEVEL1) {
      if (cycles < AMASS_LEVEL2) { amass_level = 1; }
      else if (cycles < AMASS_LEVEL3) { amass_level = 2; }
      else { amass_level = 3; }
      cycles >>= amass_level;
    }
    if (cycles >= (1UL << 16)) { cycles = 0xffff; }
    block_s += (double)(n_step << amass_level) * (double)cycles / (double)F_CPU;

    pl_block->millimeters = mm_remaining;
    prep.steps_remaining = n_steps_remaining;
    prep.dt_remainder = (n_steps_remaining - step_dist_remaining)*inv_rate;
    if (mm_remaining == prep.mm_complete) { break; }
  }
  profile_s += block_min*60.0;
  return block_s;
}

/* The dexcut block indices of the buffered blocks, oldest first (a FIFO beside the
   planner's ring). */
static long queue[BLOCK_BUFFER_SIZE];
static int queue_head, queue_len;
static double total_s;

static void execute_tail(void)
{
  plan_block_t *b = plan_get_current_block();
  long k = queue[queue_head];
  queue_head = (queue_head + 1) % BLOCK_BUFFER_SIZE;
  queue_len--;
  float mm = b->millimeters;
  float entry_sqr = b->entry_speed_sqr;
  float exit_sqr = plan_get_exec_block_exit_speed_sqr();
  float nominal = plan_compute_profile_nominal_speed(b);
  float max_entry_sqr = b->max_entry_speed_sqr;
  float accel = b->acceleration;
  double t = execute_block(b);
  total_s += t;
  printf("B %ld %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", k, sqrt(entry_sqr), sqrt(exit_sqr),
         nominal, sqrt(max_entry_sqr), mm, accel/3600.0, t);
  plan_discard_current_block();
}

static void drain(void)
{
  while (plan_get_current_block() != NULL) { execute_tail(); }
}

static void read_settings(const char *file)
{
  FILE *f = fopen(file, "r");
  if (!f) { perror(file); exit(1); }
  char line[256];
  int seen = 0;
  while (fgets(line, sizeof line, f)) {
    int n; float v;
    if (sscanf(line, "$%d=%f", &n, &v) != 2) { continue; }
    if (n == 11) { settings.junction_deviation = v; seen |= 1; }
    else if (n == 12) { settings.arc_tolerance = v; seen |= 2; }
    else if (n >= 100 && n <= 102) { settings.steps_per_mm[n-100] = v; seen |= 4 << (n-100); }
    else if (n >= 110 && n <= 112) { settings.max_rate[n-110] = v; seen |= 32 << (n-110); }
    else if (n >= 120 && n <= 122) { settings.acceleration[n-120] = v*60*60; seen |= 256 << (n-120); }
  }
  fclose(f);
  if (seen != 2047) { fprintf(stderr, "%s: $11, $12, $100-$102, $110-$112, $120-$122 needed\n", file); exit(1); }
}

int main(int argc, char **argv)
{
  if (argc != 2) { fprintf(stderr, "usage: grbl_harness SETTINGS.txt < blocks.txt\n"); return 1; }
  read_settings(argv[1]);
  sys.f_override = 100;
  sys.r_override = 100;
  plan_reset();
  char line[512];
  int lineno = 0;
  while (fgets(line, sizeof line, stdin)) {
    lineno++;
    double x, y, z, feed, dwell;
    long k;
    float target[N_AXIS];
    plan_line_data_t data;
    memset(&data, 0, sizeof data);
    if (sscanf(line, "start %lf %lf %lf", &x, &y, &z) == 3) {
      float p[N_AXIS] = {x, y, z};
      for (int i = 0; i < N_AXIS; i++) { sys_position[i] = lround(p[i]*settings.steps_per_mm[i]); }
      plan_sync_position();
      continue;
    } else if (sscanf(line, "S %lf %ld", &dwell, &k) == 2) {
      drain();
      printf("S %ld %.9g\n", k, dwell);
      total_s += dwell;
      profile_s += dwell;
      continue;
    } else if (sscanf(line, "F %lf %lf %lf %lf %ld", &x, &y, &z, &feed, &k) == 5) {
      data.feed_rate = feed;
    } else if (sscanf(line, "R %lf %lf %lf %ld", &x, &y, &z, &k) == 4) {
      data.condition = PL_COND_FLAG_RAPID_MOTION;
    } else {
      fprintf(stderr, "line %d: cannot read `%s`\n", lineno, line);
      return 1;
    }
    target[0] = x; target[1] = y; target[2] = z;
    /* mc_line: wait (the stepper runs the tail) while the buffer is full. */
    while (plan_check_full_buffer()) { execute_tail(); }
    if (plan_buffer_line(target, &data) == PLAN_EMPTY_BLOCK) {
      printf("E %ld\n", k);
      continue;
    }
    queue[(queue_head + queue_len) % BLOCK_BUFFER_SIZE] = k;
    queue_len++;
  }
  drain();
  printf("total %.9f %.9f\n", total_s, profile_s);
  return 0;
}
