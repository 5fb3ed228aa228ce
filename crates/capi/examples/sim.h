/* A small braking simulator in C: the system under test brakes once the time to collision falls
 * below its horizon (after a reaction latency); the run fails if it hits the obstacle. Its
 * fidelity settings (rate, integrator, latency, horizon) change both the outcome and the cost.
 * Deterministic: the cost is counted in work units, so a campaign gives the same trials on any
 * machine. */
#ifndef SAVME_EXAMPLE_SIM_H
#define SAVME_EXAMPLE_SIM_H

#ifdef __cplusplus
extern "C" {
#endif

/* The outcome of one run. */
typedef struct {
  int failure;       /* the ego hit the obstacle */
  double runtime;    /* work units (> 0) */
  double robustness; /* the smallest distance left, metres (<= 0: failed) */
} sim_result;

/* The settings of one run. */
typedef struct {
  double rate_hz;   /* simulation rate */
  int exact;        /* exact (1) or Euler (0) integration */
  int skip_latency; /* no reaction latency (a shortcut of the low fidelity) */
  double horizon_s; /* the time-to-collision threshold of the braking rule */
} sim_fidelity;

/* Runs scenario `lead_brakes` (cut_in = 0: the lead car, at the ego's speed, brakes hard) or
 * `cut_in` (cut_in = 1: a slower car cuts in at `gap`), `wet` road or dry. */
sim_result sim_run(int cut_in, double speed, double gap, int wet, const sim_fidelity *f);

#ifdef __cplusplus
}
#endif

#endif
