// The C harness's campaign (../c/harness.c) in C++17 through the header-only wrapper
// savme.hpp: RAII handles, exceptions, string views. Prints the same lines as the C harness,
// so the tests check that both give the same trials (and the Rust API too).
//
//   harness_cpp --config FILE [--train N] [--evaluate N] [--baseline N] [--batch K] [--builder 1]
//
// With --builder 1 the kernel comes from savme::builder (the configuration of config.json put
// together in code) instead of the file: the same kernel, so the same trials.
#include <savme.hpp>

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "../sim.h"

namespace {

uint64_t bits(double x) {
  uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

void print_value(const savme::value &v) {
  std::printf("%.*s=", static_cast<int>(v.name().size()), v.name().data());
  switch (v.type()) {
  case SAVME_TYPE_BOOL: std::printf("b:%d", v.boolean() ? 1 : 0); break;
  case SAVME_TYPE_INT: std::printf("i:%" PRId64, v.integer()); break;
  case SAVME_TYPE_REAL: std::printf("r:%016" PRIx64, bits(v.real())); break;
  case SAVME_TYPE_LABEL: std::printf("s:%.*s", static_cast<int>(v.label().size()), v.label().data()); break;
  }
}

void print_part(const savme::trial &t, savme_part part) {
  std::printf("[");
  for (size_t i = 0, n = t.count(part); i < n; i++) {
    if (i) std::printf(",");
    print_value(t.at(part, i));
  }
  std::printf("]");
}

sim_result simulate(const savme::trial &t, savme_part part) {
  bool cut_in = t.scenario() == "cut_in";
  bool wet = cut_in && t.find(SAVME_PHI, "road").label() == "wet";
  sim_fidelity f;
  f.rate_hz = t.number(part, "rate_hz");
  f.exact = t.find(part, "integrator").label() == "exact";
  f.skip_latency = t.find(part, "skip_latency").boolean();
  f.horizon_s = t.number(part, "horizon_s");
  return sim_run(cut_in, t.number(SAVME_PHI, "speed"), t.number(SAVME_PHI, "gap"), wet, &f);
}

savme_run run_of(const sim_result &r) { return savme::run(r.failure != 0, r.runtime, r.robustness); }

const char *const PHASES[] = {"train", "evaluate", "baseline", "test"};

void run_and_tell(savme::kernel &k, const savme::trial &t) {
  sim_result hf = simulate(t, SAVME_THETA_HF);
  std::string_view scenario = t.scenario();
  std::printf("trial %" PRIu64 " %s %.*s phi", t.id(), PHASES[t.phase()], static_cast<int>(scenario.size()),
              scenario.data());
  print_part(t, SAVME_PHI);
  std::printf(" hf=%d/%016" PRIx64 "/%016" PRIx64, hf.failure, bits(hf.runtime), bits(hf.robustness));
  if (t.paired()) {
    sim_result lf = simulate(t, SAVME_THETA_LF);
    std::printf(" lf");
    print_part(t, SAVME_THETA_LF);
    std::printf("=%d/%016" PRIx64 "/%016" PRIx64, lf.failure, bits(lf.runtime), bits(lf.robustness));
    k.tell_paired(t.id(), run_of(hf), run_of(lf));
  } else {
    k.tell_hf_only(t.id(), run_of(hf));
  }
  std::printf("\n");
}

struct options {
  std::string config;
  bool builder = false;
  long counts[3] = {60, 20, 20};
  long batch = 1;
};

void campaign(savme::kernel &k, const options &o) {
  std::vector<savme::trial> trials(static_cast<size_t>(o.batch));
  std::vector<savme_trial *> handles;
  for (const auto &t : trials) handles.push_back(t.get());
  const savme_phase order[3] = {SAVME_PHASE_TRAIN, SAVME_PHASE_EVALUATE, SAVME_PHASE_BASELINE};
  long end = 0;
  for (int p = 0; p < 3; p++) {
    end += o.counts[p];
    if (static_cast<long>(k.stats().told) >= end) continue;
    if (k.phase() != order[p]) k.set_phase(order[p]);
    for (long told = static_cast<long>(k.stats().told); told < end; told = static_cast<long>(k.stats().told)) {
      long n = std::min(end - told, o.batch);
      if (n == 1) k.ask(trials[0]);
      else k.ask_batch(handles.data(), static_cast<size_t>(n));
      for (long i = 0; i < n; i++) run_and_tell(k, trials[static_cast<size_t>(i)]);
    }
  }
}

void report(const savme::kernel &k) {
  savme::assignment best;
  double evidence = k.estimate(best); // the configuration's estimator: evidence in config.json
  std::printf("theta_lf* [");
  for (size_t i = 0; i < best.size(); i++) {
    if (i) std::printf(",");
    print_value(best.at(i));
  }
  std::printf("] evidence=%016" PRIx64 "\n", bits(evidence));
  std::printf("settings %s\n", k.estimate_evidence().c_str());
  for (size_t var = 0; var < k.posterior_size(nullptr); var++) {
    auto [name, arms] = k.posterior_variable(nullptr, var);
    std::printf("posterior %.*s", static_cast<int>(name.size()), name.data());
    for (size_t a = 0; a < arms; a++) {
      auto [alpha, beta] = k.arm(nullptr, var, a);
      std::printf(" %g/%g", alpha, beta);
    }
    std::printf("\n");
  }
  savme_stats st = k.stats();
  std::printf("stats asked=%" PRIu64 " told=%" PRIu64 " cancelled=%" PRIu64 " pending=%" PRIu64 "\n", st.asked,
              st.told, st.cancelled, st.pending);
}

void snapshot_round_trip(const savme::kernel &k) {
  std::string snapshot = k.snapshot();
  savme::kernel a = savme::kernel::from_snapshot(snapshot), b = savme::kernel::from_snapshot(snapshot);
  savme::trial ta, tb;
  a.ask(ta);
  b.ask(tb);
  bool same = ta.number(SAVME_PHI, "gap") == tb.number(SAVME_PHI, "gap");
  std::printf("snapshot restored twice: same next trial: %s\n", same ? "yes" : "no");
}

void estimation(savme::kernel &k) {
  savme::trial t;
  k.estimation_start("{\"epsilon\":0.2,\"seed\":3}");
  for (int i = 0; i < 30 && k.estimation_ask(t); i++) {
    sim_result hf = simulate(t, SAVME_THETA_HF);
    std::string_view scenario = t.scenario();
    std::printf("estimation %" PRIu64 " %.*s phi", t.id(), static_cast<int>(scenario.size()), scenario.data());
    print_part(t, SAVME_PHI);
    std::printf(" weight=%016" PRIx64 " hf=%d/%016" PRIx64 "\n", bits(t.weight()), hf.failure, bits(hf.robustness));
    k.estimation_tell(t.id(), hf.failure != 0, hf.robustness);
  }
  std::printf("estimation result %s\n", k.estimation_result().c_str());
}

/// config.json's configuration in code.
savme::builder example_builder() {
  savme::builder b(7, 0.3);
  b.fidelity_ints("rate_hz", {5, 10, 20, 50}, 50)
      .fidelity_labels("integrator", {"euler", "exact"}, "exact")
      .fidelity_bool("skip_latency", false)
      .fidelity_continuous("horizon_s", 1.0, 4.0, 3, false, 4.0)
      .scenario("lead_brakes")
      .phi_continuous("lead_brakes", "speed", 5.0, 30.0, 5)
      .phi_continuous("lead_brakes", "gap", 5.0, 60.0, 5)
      .scenario("cut_in")
      .phi_continuous("cut_in", "speed", 5.0, 30.0, 5)
      .phi_continuous("cut_in", "gap", 2.0, 30.0, 4)
      .phi_labels("cut_in", "road", {"dry", "wet"});
  return b;
}

} // namespace

int main(int argc, char **argv) {
  options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i];
    const char *v = argv[i + 1];
    if (a == "--config") o.config = v;
    else if (a == "--train") o.counts[0] = std::atol(v);
    else if (a == "--evaluate") o.counts[1] = std::atol(v);
    else if (a == "--baseline") o.counts[2] = std::atol(v);
    else if (a == "--batch") o.batch = std::atol(v);
    else if (a == "--builder") o.builder = std::atol(v) != 0;
    else {
      std::cerr << "harness_cpp: unknown argument " << a << "\n";
      return 2;
    }
  }
  if (o.config.empty() || o.batch < 1) {
    std::cerr << "usage: harness_cpp --config FILE [--batch K] [...]\n";
    return 2;
  }
  try {
    std::ifstream in(o.config);
    std::stringstream text;
    text << in.rdbuf();
    savme::kernel k = o.builder ? example_builder().build() : savme::kernel::from_config(text.str());
    campaign(k, o);
    report(k);
    snapshot_round_trip(k);
    estimation(k);
    std::printf("request %s\n", k.request("{\"op\":\"stats\"}").c_str());
    // A refused call throws, naming the trial: tell trial 0 again.
    try {
      k.tell_hf_only(0, savme::run(false, 1.0));
    } catch (const savme::error &e) {
      std::printf("refused (%d): %s\n", static_cast<int>(e.status()), e.what());
    }
  } catch (const savme::error &e) {
    std::cerr << "harness_cpp: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
