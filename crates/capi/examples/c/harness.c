/* A C test harness driving savme through its C ABI: the campaign loop (ask, run the HF and LF
 * simulators, tell) against the small braking simulator of ../sim.c, then θ_LF*, the fidelity
 * posterior, a snapshot round trip and an estimation of P(failure).
 *
 *   harness --config FILE [--train N] [--evaluate N] [--baseline N] [--batch K]
 *           [--journal FILE [--die-after-ask N]] [--snapshot-out FILE]
 *
 * Prints one line per told trial (values exactly: reals as the hex of their bits), so that the
 * tests compare it with the same campaign through the Rust API and with the C++ harness.
 * With --journal the campaign resumes where a killed run stopped (--die-after-ask N kills this
 * process with SIGKILL right after the ask that reaches N asked trials, to test just that). */
#include <savme.h>

#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../sim.h"

/* Stops the harness with the library's message if a call failed. */
#define CHECK(call)                                                                           \
  do {                                                                                        \
    savme_status s_ = (call);                                                                 \
    if (s_ != SAVME_OK) {                                                                     \
      fprintf(stderr, "harness: %s failed (%s): %s\n", #call, savme_status_name(s_),         \
              savme_last_error());                                                            \
      exit(1);                                                                                \
    }                                                                                         \
  } while (0)

static char *read_file(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "harness: cannot open %s\n", path);
    exit(1);
  }
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *text = malloc((size_t)n + 1);
  if (!text || fread(text, 1, (size_t)n, f) != (size_t)n) {
    fprintf(stderr, "harness: cannot read %s\n", path);
    exit(1);
  }
  text[n] = '\0';
  fclose(f);
  return text;
}

static uint64_t bits(double x) {
  uint64_t b;
  memcpy(&b, &x, sizeof b);
  return b;
}

/* Prints one value exactly: b:0/1, i:integer, r:hex bits, s:label. */
static void print_value(const savme_value *v) {
  printf("%.*s=", (int)v->name.len, v->name.ptr);
  switch (v->kind) {
  case SAVME_TYPE_BOOL: printf("b:%d", v->boolean ? 1 : 0); break;
  case SAVME_TYPE_INT: printf("i:%" PRId64, v->integer); break;
  case SAVME_TYPE_REAL: printf("r:%016" PRIx64, bits(v->real)); break;
  case SAVME_TYPE_LABEL: printf("s:%.*s", (int)v->label.len, v->label.ptr); break;
  }
}

/* Prints part `part` of trial `t` by index: [name=value,...]. */
static void print_part(const savme_trial *t, savme_part part) {
  size_t n;
  CHECK(savme_trial_count(t, part, &n));
  printf("[");
  for (size_t i = 0; i < n; i++) {
    savme_value v;
    CHECK(savme_trial_value(t, part, i, &v));
    if (i) printf(",");
    print_value(&v);
  }
  printf("]");
}

/* The simulator's settings from part `part` (θ_HF or θ_LF) of trial `t`, read by name. */
static sim_fidelity fidelity_of(const savme_trial *t, savme_part part) {
  sim_fidelity f;
  savme_value v;
  CHECK(savme_trial_number(t, part, "rate_hz", &f.rate_hz));
  CHECK(savme_trial_find(t, part, "integrator", &v));
  f.exact = v.label.len == 5 && memcmp(v.label.ptr, "exact", 5) == 0;
  CHECK(savme_trial_find(t, part, "skip_latency", &v));
  f.skip_latency = v.boolean;
  CHECK(savme_trial_number(t, part, "horizon_s", &f.horizon_s));
  return f;
}

/* Runs trial `t`'s scenario at the settings of `part`. */
static sim_result simulate(const savme_trial *t, savme_part part) {
  savme_str scenario;
  double speed, gap;
  int wet = 0;
  CHECK(savme_trial_scenario(t, &scenario, NULL));
  int cut_in = scenario.len == 6 && memcmp(scenario.ptr, "cut_in", 6) == 0;
  CHECK(savme_trial_number(t, SAVME_PHI, "speed", &speed));
  CHECK(savme_trial_number(t, SAVME_PHI, "gap", &gap));
  if (cut_in) {
    savme_value road;
    CHECK(savme_trial_find(t, SAVME_PHI, "road", &road));
    wet = road.label.len == 3 && memcmp(road.label.ptr, "wet", 3) == 0;
  }
  sim_fidelity f = fidelity_of(t, part);
  return sim_run(cut_in, speed, gap, wet, &f);
}

static savme_run run_of(sim_result r) {
  savme_run run = {r.failure != 0, r.runtime, true, r.robustness};
  return run;
}

static const char *const PHASES[] = {"train", "evaluate", "baseline", "test"};

/* Runs trial `t` on HF (and LF if paired), tells the kernel and prints the trial's line. */
static void run_and_tell(savme_kernel *k, const savme_trial *t) {
  uint64_t id;
  savme_phase phase;
  bool paired;
  savme_str scenario;
  CHECK(savme_trial_id(t, &id));
  CHECK(savme_trial_phase(t, &phase));
  CHECK(savme_trial_is_paired(t, &paired));
  CHECK(savme_trial_scenario(t, &scenario, NULL));
  sim_result hf = simulate(t, SAVME_THETA_HF);
  printf("trial %" PRIu64 " %s %.*s phi", id, PHASES[phase], (int)scenario.len, scenario.ptr);
  print_part(t, SAVME_PHI);
  printf(" hf=%d/%016" PRIx64 "/%016" PRIx64, hf.failure, bits(hf.runtime), bits(hf.robustness));
  if (paired) {
    sim_result lf = simulate(t, SAVME_THETA_LF);
    printf(" lf");
    print_part(t, SAVME_THETA_LF);
    printf("=%d/%016" PRIx64 "/%016" PRIx64, lf.failure, bits(lf.runtime), bits(lf.robustness));
    CHECK(savme_tell_paired(k, id, run_of(hf), run_of(lf), NULL));
  } else {
    CHECK(savme_tell_hf_only(k, id, run_of(hf), NULL));
  }
  printf("\n");
}

typedef struct {
  const char *config, *journal, *snapshot_out;
  long counts[3]; /* train, evaluate, baseline */
  long batch, die_after_ask;
} options;

static options parse(int argc, char **argv) {
  options o = {NULL, NULL, NULL, {60, 20, 20}, 1, -1};
  for (int i = 1; i + 1 < argc; i += 2) {
    const char *a = argv[i], *v = argv[i + 1];
    if (!strcmp(a, "--config")) o.config = v;
    else if (!strcmp(a, "--journal")) o.journal = v;
    else if (!strcmp(a, "--snapshot-out")) o.snapshot_out = v;
    else if (!strcmp(a, "--train")) o.counts[0] = atol(v);
    else if (!strcmp(a, "--evaluate")) o.counts[1] = atol(v);
    else if (!strcmp(a, "--baseline")) o.counts[2] = atol(v);
    else if (!strcmp(a, "--batch")) o.batch = atol(v);
    else if (!strcmp(a, "--die-after-ask")) o.die_after_ask = atol(v);
    else {
      fprintf(stderr, "harness: unknown argument %s\n", a);
      exit(2);
    }
  }
  if (!o.config || o.batch < 1 || o.batch > 64) {
    fprintf(stderr, "usage: harness --config FILE [--batch 1..64] [...]\n");
    exit(2);
  }
  return o;
}

/* The campaign: each phase's trials, asked `batch` at a time; resumes from the kernel's
 * counters (a journal that was replayed), telling the trials pending at the crash first. */
static void campaign(savme_kernel *k, const options *o) {
  savme_trial *trials[64];
  for (int i = 0; i < 64; i++) CHECK(savme_trial_new(&trials[i]));
  savme_stats st;
  CHECK(savme_get_stats(k, &st));
  for (uint64_t i = 0; i < st.pending; i++) {
    CHECK(savme_pending_trial(k, 0, trials[0])); /* the first pending, each time */
    run_and_tell(k, trials[0]);
  }
  static const savme_phase order[3] = {SAVME_PHASE_TRAIN, SAVME_PHASE_EVALUATE, SAVME_PHASE_BASELINE};
  long done_before = 0;
  for (int p = 0; p < 3; p++) {
    long end = done_before + o->counts[p];
    done_before = end;
    CHECK(savme_get_stats(k, &st));
    if ((long)st.told >= end) continue;
    savme_phase now;
    CHECK(savme_get_phase(k, &now));
    if (now != order[p]) CHECK(savme_set_phase(k, order[p]));
    while ((long)st.told < end) {
      long n = end - (long)st.told < o->batch ? end - (long)st.told : o->batch;
      if (n == 1) CHECK(savme_ask(k, trials[0]));
      else CHECK(savme_ask_batch(k, trials, (size_t)n));
      if (o->die_after_ask >= 0 && (long)st.asked + n >= o->die_after_ask) {
        fflush(stdout);
        raise(SIGKILL); /* as kill -9 would: the journal holds the ask, nothing else runs */
      }
      for (long i = 0; i < n; i++) run_and_tell(k, trials[i]);
      CHECK(savme_get_stats(k, &st));
    }
  }
  for (int i = 0; i < 64; i++) CHECK(savme_trial_free(trials[i]));
}

/* θ_LF*, the evidence and the fidelity posterior. */
static void report(savme_kernel *k) {
  savme_assignment *best;
  double evidence;
  size_t n;
  CHECK(savme_assignment_new(&best));
  /* The configuration's estimator (evidence in config.json, savme's tuned default). */
  CHECK(savme_estimate(k, SAVME_ESTIMATOR_CONFIGURED, best, &evidence));
  CHECK(savme_assignment_count(best, &n));
  printf("theta_lf* [");
  for (size_t i = 0; i < n; i++) {
    savme_value v;
    CHECK(savme_assignment_value(best, i, &v));
    if (i) printf(",");
    print_value(&v);
  }
  printf("] evidence=%016" PRIx64 "\n", bits(evidence));
  CHECK(savme_assignment_free(best));
  /* Each chosen setting's tries, false-alarm and miss rates (serve's estimate `settings`). */
  char *settings;
  CHECK(savme_estimate_evidence(k, SAVME_ESTIMATOR_CONFIGURED, &settings));
  printf("settings %s\n", settings);
  CHECK(savme_string_free(settings));
  CHECK(savme_posterior_count(k, NULL, &n));
  for (size_t var = 0; var < n; var++) {
    savme_str name;
    size_t arms;
    CHECK(savme_posterior_variable(k, NULL, var, &name, &arms));
    printf("posterior %.*s", (int)name.len, name.ptr);
    for (size_t a = 0; a < arms; a++) {
      double alpha, beta;
      CHECK(savme_posterior_arm(k, NULL, var, a, &alpha, &beta));
      printf(" %g/%g", alpha, beta);
    }
    printf("\n");
  }
  savme_stats st;
  CHECK(savme_get_stats(k, &st));
  printf("stats asked=%" PRIu64 " told=%" PRIu64 " cancelled=%" PRIu64 " pending=%" PRIu64 "\n",
         st.asked, st.told, st.cancelled, st.pending);
}

/* A snapshot restored twice asks the same trial twice; the kernel itself is not changed. */
static void snapshot_round_trip(savme_kernel *k, const char *out) {
  char *data;
  size_t len;
  CHECK(savme_snapshot(k, &data, &len));
  if (out) {
    FILE *f = fopen(out, "wb");
    if (!f || fwrite(data, 1, len, f) != len) exit(1);
    fclose(f);
  }
  savme_kernel *a, *b;
  savme_trial *ta, *tb;
  CHECK(savme_kernel_from_snapshot((const uint8_t *)data, len, &a));
  CHECK(savme_kernel_from_snapshot((const uint8_t *)data, len, &b));
  CHECK(savme_string_free(data));
  CHECK(savme_trial_new(&ta));
  CHECK(savme_trial_new(&tb));
  CHECK(savme_ask(a, ta));
  CHECK(savme_ask(b, tb));
  double ga, gb;
  CHECK(savme_trial_number(ta, SAVME_PHI, "gap", &ga));
  CHECK(savme_trial_number(tb, SAVME_PHI, "gap", &gb));
  printf("snapshot restored twice: same next trial: %s\n", ga == gb ? "yes" : "no");
  CHECK(savme_trial_free(ta));
  CHECK(savme_trial_free(tb));
  CHECK(savme_kernel_free(a));
  CHECK(savme_kernel_free(b));
}

/* P(failure) under the nominal by importance sampling from the learned posteriors. */
static void estimation(savme_kernel *k) {
  savme_trial *t;
  CHECK(savme_trial_new(&t));
  CHECK(savme_estimation_start(k, "{\"epsilon\":0.2,\"seed\":3}"));
  for (int i = 0; i < 30; i++) {
    bool asked;
    CHECK(savme_estimation_ask(k, t, &asked));
    if (!asked) break;
    uint64_t id;
    double weight;
    CHECK(savme_trial_id(t, &id));
    CHECK(savme_trial_densities(t, NULL, NULL, &weight, NULL));
    savme_str scenario;
    CHECK(savme_trial_scenario(t, &scenario, NULL));
    sim_result hf = simulate(t, SAVME_THETA_HF);
    printf("estimation %" PRIu64 " %.*s phi", id, (int)scenario.len, scenario.ptr);
    print_part(t, SAVME_PHI);
    printf(" weight=%016" PRIx64 " hf=%d/%016" PRIx64 "\n", bits(weight), hf.failure, bits(hf.robustness));
    CHECK(savme_estimation_tell(k, id, hf.failure != 0, true, hf.robustness));
  }
  CHECK(savme_trial_free(t));
  char *result;
  CHECK(savme_estimation_result(k, &result));
  printf("estimation result %s\n", result);
  CHECK(savme_string_free(result));
}

int main(int argc, char **argv) {
  setvbuf(stdout, NULL, _IOLBF, 0); /* every line out before a kill */
  if (savme_abi_version() != SAVME_ABI_VERSION) {
    fprintf(stderr, "harness: savme.h is ABI %d, libsavme %u (%s)\n", SAVME_ABI_VERSION,
            savme_abi_version(), savme_version());
    return 1;
  }
  options o = parse(argc, argv);
  char *config = read_file(o.config);
  savme_kernel *k;
  if (o.journal) {
    CHECK(savme_kernel_open_journal(o.journal, config, &k));
    savme_journal_info info;
    CHECK(savme_journal_info_of(k, &info));
    if (info.resumed)
      fprintf(stderr, "harness: resumed %s: %" PRIu64 " told, %" PRIu64 " pending\n", o.journal,
              info.told, info.pending);
  } else {
    CHECK(savme_kernel_new(config, &k));
  }
  free(config);
  campaign(k, &o);
  report(k);
  snapshot_round_trip(k, o.snapshot_out);
  estimation(k);
  char *response;
  CHECK(savme_request(k, "{\"op\":\"stats\"}", &response));
  printf("request %s\n", response);
  CHECK(savme_string_free(response));
  CHECK(savme_kernel_free(k));
  return 0;
}
