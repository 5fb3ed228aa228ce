#include "sim.h"

sim_result sim_run(int cut_in, double speed, double gap, int wet, const sim_fidelity *f) {
  const double dt = 1.0 / f->rate_hz;
  const double decel = wet ? 5.0 : 8.0;
  const double latency = f->skip_latency ? 0.0 : 0.3;
  double ego_x = 0.0, ego_v = speed;
  double lead_x = gap, lead_v = cut_in ? 0.5 * speed : speed;
  const double lead_decel = cut_in ? 0.0 : 6.0;
  double brake_at = -1.0; /* when the ego starts braking; < 0: not yet decided */
  double min_gap = gap;
  long steps = 0;
  sim_result r = {0, 0.0, gap};
  for (double t = 0.0; t < 30.0; t += dt) {
    double d = lead_x - ego_x;
    double closing = ego_v - lead_v;
    if (brake_at < 0.0 && closing > 0.0 && d / closing < f->horizon_s) {
      brake_at = t + latency;
    }
    double a_ego = (brake_at >= 0.0 && t >= brake_at) ? -decel : 0.0;
    double a_lead = lead_v > 0.0 ? -lead_decel : 0.0;
    if (f->exact) {
      ego_x += ego_v * dt + 0.5 * a_ego * dt * dt;
      lead_x += lead_v * dt + 0.5 * a_lead * dt * dt;
    } else {
      ego_x += ego_v * dt;
      lead_x += lead_v * dt;
    }
    ego_v += a_ego * dt;
    lead_v += a_lead * dt;
    if (ego_v < 0.0) ego_v = 0.0;
    if (lead_v < 0.0) lead_v = 0.0;
    steps++;
    d = lead_x - ego_x;
    if (d < min_gap) min_gap = d;
    if (d <= 0.0) {
      r.failure = 1;
      break;
    }
    if (ego_v <= lead_v && brake_at >= 0.0 && t >= brake_at) break; /* no longer closing */
    if (ego_v == 0.0) break;
  }
  r.runtime = (double)steps * (f->exact ? 1.5 : 1.0) + 1.0;
  r.robustness = min_gap;
  return r;
}
