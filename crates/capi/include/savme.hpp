// savme.hpp: a header-only C++17 wrapper over savme.h (the C ABI of savme). RAII handles
// (kernel, trial, assignment: move-only, freed in their destructors), exceptions for failed
// calls (savme::error, carrying the status and the library's message) and std::string_view
// for the strings a handle owns. Licence: MIT OR Apache-2.0.
//
//   savme::kernel k = savme::kernel::from_config(json);
//   savme::trial t;
//   k.ask(t);
//   double gap = t.number(SAVME_PHI, "gap");
//   k.tell_paired(t.id(), savme::run(hf_failed, hf_cost), savme::run(lf_failed, lf_cost));
//
// Thread-safety: as savme.h says (every handle may be used from any thread; calls on one
// handle are serialised). Views (std::string_view) a trial hands out are valid until the
// trial is filled again or destroyed.
#ifndef SAVME_HPP
#define SAVME_HPP

#include "savme.h"

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace savme {

/// A call that did not return SAVME_OK: its status and the library's message.
class error : public std::runtime_error {
public:
  error(savme_status status, const char *message) : std::runtime_error(message), status_(status) {}
  /// Why the call failed.
  savme_status status() const noexcept { return status_; }

private:
  savme_status status_;
};

/// Throws savme::error with this thread's last error unless `s` is SAVME_OK.
inline void check(savme_status s) {
  if (s != SAVME_OK) throw error(s, savme_last_error());
}

/// A view of a string the library owns.
inline std::string_view view(savme_str s) { return std::string_view(s.ptr, s.len); }

/// One run: failure, cost and, optionally, robustness (≤ 0 failed).
inline savme_run run(bool failure, double runtime, std::optional<double> robustness = std::nullopt) {
  return savme_run{failure, runtime, robustness.has_value(), robustness.value_or(0.0)};
}

/// A value read from a trial or an assignment.
struct value {
  savme_value raw;
  std::string_view name() const { return view(raw.name); }
  savme_type type() const { return raw.kind; }
  bool boolean() const { return raw.boolean; }
  int64_t integer() const { return raw.integer; }
  double real() const { return raw.real; }
  std::string_view label() const { return view(raw.label); }
};

/// Owns a handle of type T, freed by Free in the destructor (move-only).
template <typename T, savme_status (*Free)(T *)> class handle {
public:
  handle() = default;
  explicit handle(T *h) : h_(h) {}
  handle(const handle &) = delete;
  handle &operator=(const handle &) = delete;
  handle(handle &&o) noexcept : h_(std::exchange(o.h_, nullptr)) {}
  handle &operator=(handle &&o) noexcept {
    if (this != &o) {
      reset();
      h_ = std::exchange(o.h_, nullptr);
    }
    return *this;
  }
  ~handle() { reset(); }
  T *get() const noexcept { return h_; }

private:
  void reset() noexcept {
    if (h_) Free(h_);
    h_ = nullptr;
  }
  T *h_ = nullptr;
};

/// A trial handle, reused by every ask that fills it.
class trial {
public:
  trial() {
    savme_trial *t = nullptr;
    check(savme_trial_new(&t));
    h_ = handle<savme_trial, savme_trial_free>(t);
  }
  savme_trial *get() const noexcept { return h_.get(); }
  uint64_t id() const {
    uint64_t id;
    check(savme_trial_id(get(), &id));
    return id;
  }
  savme_phase phase() const {
    savme_phase p;
    check(savme_trial_phase(get(), &p));
    return p;
  }
  std::string_view scenario() const {
    savme_str s;
    check(savme_trial_scenario(get(), &s, nullptr));
    return view(s);
  }
  bool paired() const {
    bool p;
    check(savme_trial_is_paired(get(), &p));
    return p;
  }
  size_t count(savme_part part) const {
    size_t n;
    check(savme_trial_count(get(), part, &n));
    return n;
  }
  value at(savme_part part, size_t index) const {
    value v;
    check(savme_trial_value(get(), part, index, &v.raw));
    return v;
  }
  value find(savme_part part, const char *name) const {
    value v;
    check(savme_trial_find(get(), part, name, &v.raw));
    return v;
  }
  double number(savme_part part, const char *name) const {
    double x;
    check(savme_trial_number(get(), part, name, &x));
    return x;
  }
  /// An estimation trial's weight p/q.
  double weight() const {
    double w;
    check(savme_trial_densities(get(), nullptr, nullptr, &w, nullptr));
    return w;
  }

private:
  handle<savme_trial, savme_trial_free> h_;
};

/// An assignment handle (θ_LF*, θ_HF).
class assignment {
public:
  assignment() {
    savme_assignment *a = nullptr;
    check(savme_assignment_new(&a));
    h_ = handle<savme_assignment, savme_assignment_free>(a);
  }
  savme_assignment *get() const noexcept { return h_.get(); }
  size_t size() const {
    size_t n;
    check(savme_assignment_count(get(), &n));
    return n;
  }
  value at(size_t index) const {
    value v;
    check(savme_assignment_value(get(), index, &v.raw));
    return v;
  }
  value find(const char *name) const {
    value v;
    check(savme_assignment_find(get(), name, &v.raw));
    return v;
  }

private:
  handle<savme_assignment, savme_assignment_free> h_;
};

/// A string the library gave out, freed in the destructor, as std::string.
inline std::string take_string(char *s, size_t len) {
  std::string out(s, len);
  savme_string_free(s);
  return out;
}

class kernel;

/// A kernel configuration put together variable by variable (the common case; everything
/// else at its default). `config()` gives its JSON, `build()` the kernel.
class builder {
public:
  builder(uint64_t seed, double budget) {
    savme_builder *b = nullptr;
    check(savme_builder_new(seed, budget, &b));
    h_ = handle<savme_builder, savme_builder_free>(b);
  }
  savme_builder *get() const noexcept { return h_.get(); }
  builder &fidelity_ints(const char *name, const std::vector<int64_t> &values, int64_t hf) {
    check(savme_builder_fidelity_ints(get(), name, values.data(), values.size(), hf));
    return *this;
  }
  builder &fidelity_labels(const char *name, const std::vector<const char *> &values, const char *hf) {
    check(savme_builder_fidelity_labels(get(), name, values.data(), values.size(), hf));
    return *this;
  }
  builder &fidelity_bool(const char *name, bool hf) {
    check(savme_builder_fidelity_bool(get(), name, hf));
    return *this;
  }
  builder &fidelity_continuous(const char *name, double lo, double hi, uint32_t bins, bool log_scale, double hf) {
    check(savme_builder_fidelity_continuous(get(), name, lo, hi, bins, log_scale, hf));
    return *this;
  }
  builder &scenario(const char *name, double weight = 1.0) {
    check(savme_builder_scenario(get(), name, weight));
    return *this;
  }
  builder &phi_continuous(const char *scenario, const char *name, double lo, double hi, uint32_t bins,
                          bool log_scale = false) {
    check(savme_builder_phi_continuous(get(), scenario, name, lo, hi, bins, log_scale));
    return *this;
  }
  builder &phi_ints(const char *scenario, const char *name, const std::vector<int64_t> &values) {
    check(savme_builder_phi_ints(get(), scenario, name, values.data(), values.size()));
    return *this;
  }
  builder &phi_labels(const char *scenario, const char *name, const std::vector<const char *> &values) {
    check(savme_builder_phi_labels(get(), scenario, name, values.data(), values.size()));
    return *this;
  }
  builder &phi_bool(const char *scenario, const char *name) {
    check(savme_builder_phi_bool(get(), scenario, name));
    return *this;
  }
  /// The method the kernel starts from (default `SAVME_METHOD_TUNED`: θ_LF* by evidence).
  builder &method(savme_method m) {
    check(savme_builder_method(get(), m));
    return *this;
  }
  /// θ_LF*'s choice alone (`SAVME_ESTIMATOR_MAP`: the paper's; `_CONFIGURED`: the method's).
  builder &estimator(savme_estimator e) {
    check(savme_builder_estimator(get(), e));
    return *this;
  }
  /// The configuration as JSON (for a journal, or `savme serve --config`).
  std::string config() const {
    char *json;
    check(savme_builder_config(get(), &json));
    std::string out(json);
    savme_string_free(json);
    return out;
  }
  /// The kernel (in memory).
  kernel build() const;

private:
  handle<savme_builder, savme_builder_free> h_;
};

/// The kernel.
class kernel {
public:
  /// A kernel in memory from a JSON configuration (as `savme example-config` prints).
  static kernel from_config(const std::string &config_json) {
    savme_kernel *k = nullptr;
    check(savme_kernel_new(config_json.c_str(), &k));
    return kernel(k);
  }
  /// A kernel journaled to `path`: started with `config_json` or resumed (config optional).
  static kernel open_journal(const std::string &path, const std::optional<std::string> &config_json) {
    savme_kernel *k = nullptr;
    check(savme_kernel_open_journal(path.c_str(), config_json ? config_json->c_str() : nullptr, &k));
    return kernel(k);
  }
  /// A kernel restored from `snapshot()`'s bytes.
  static kernel from_snapshot(std::string_view bytes) {
    savme_kernel *k = nullptr;
    check(savme_kernel_from_snapshot(reinterpret_cast<const uint8_t *>(bytes.data()), bytes.size(), &k));
    return kernel(k);
  }
  savme_kernel *get() const noexcept { return h_.get(); }

  void ask(const trial &t) { check(savme_ask(get(), t.get())); }
  /// Asks `n` trials into `trials[0..n)` (distinct handles), all or none.
  void ask_batch(savme_trial *const *trials, size_t n) { check(savme_ask_batch(get(), trials, n)); }
  savme_record tell_paired(uint64_t id, savme_run hf, savme_run lf) {
    savme_record r;
    check(savme_tell_paired(get(), id, hf, lf, &r));
    return r;
  }
  savme_record tell_hf_only(uint64_t id, savme_run hf) {
    savme_record r;
    check(savme_tell_hf_only(get(), id, hf, &r));
    return r;
  }
  void cancel(uint64_t id) { check(savme_cancel(get(), id)); }
  void set_phase(savme_phase p) { check(savme_set_phase(get(), p)); }
  savme_phase phase() const {
    savme_phase p;
    check(savme_get_phase(get(), &p));
    return p;
  }
  savme_stats stats() const {
    savme_stats s;
    check(savme_get_stats(get(), &s));
    return s;
  }
  savme_journal_info journal_info() const {
    savme_journal_info i;
    check(savme_journal_info_of(get(), &i));
    return i;
  }
  void pending_trial(size_t index, const trial &t) { check(savme_pending_trial(get(), index, t.get())); }
  /// θ_LF* into `out`; returns the evidence behind it (0: nothing learned yet).
  double estimate(const assignment &out, savme_estimator e = SAVME_ESTIMATOR_CONFIGURED) const {
    double evidence;
    check(savme_estimate(get(), e, out.get(), &evidence));
    return evidence;
  }
  /// Per fidelity setting, θ_LF*'s arm with its tries and false-alarm and miss rates (JSON;
  /// `null` when the kernel keeps no tallies) — serve's `estimate` `settings`.
  std::string estimate_evidence(savme_estimator e = SAVME_ESTIMATOR_CONFIGURED) const {
    char *json;
    check(savme_estimate_evidence(get(), e, &json));
    std::string out(json);
    savme_string_free(json);
    return out;
  }
  std::string snapshot() const {
    char *data;
    size_t len;
    check(savme_snapshot(get(), &data, &len));
    return take_string(data, len);
  }
  /// One request of `savme serve`'s protocol; returns the response (throws on "ok":false).
  std::string request(const std::string &json) {
    char *response = nullptr;
    savme_status s = savme_request(get(), json.c_str(), &response);
    std::string out = response ? std::string(response) : std::string();
    if (response) savme_string_free(response);
    check(s);
    return out;
  }
  void estimation_start(const std::string &config_json) {
    check(savme_estimation_start(get(), config_json.c_str()));
  }
  /// Asks an estimation trial into `t`; false while a refinement round waits.
  bool estimation_ask(const trial &t) {
    bool asked;
    check(savme_estimation_ask(get(), t.get(), &asked));
    return asked;
  }
  void estimation_tell(uint64_t id, bool failure, std::optional<double> robustness = std::nullopt) {
    check(savme_estimation_tell(get(), id, failure, robustness.has_value(), robustness.value_or(0.0)));
  }
  std::string estimation_result() const {
    char *json;
    check(savme_estimation_result(get(), &json));
    std::string out(json);
    savme_string_free(json);
    return out;
  }
  /// Posterior arms: Beta(α, β) of `arm` of `variable` (scenario nullptr: the fidelity posterior).
  std::pair<double, double> arm(const char *scenario, size_t variable, size_t arm) const {
    double a, b;
    check(savme_posterior_arm(get(), scenario, variable, arm, &a, &b));
    return {a, b};
  }
  std::pair<std::string_view, size_t> posterior_variable(const char *scenario, size_t variable) const {
    savme_str name;
    size_t arms;
    check(savme_posterior_variable(get(), scenario, variable, &name, &arms));
    return {view(name), arms};
  }
  size_t posterior_size(const char *scenario) const {
    size_t n;
    check(savme_posterior_count(get(), scenario, &n));
    return n;
  }

private:
  friend class builder;
  explicit kernel(savme_kernel *k) : h_(k) {}
  handle<savme_kernel, savme_kernel_free> h_;
};

inline kernel builder::build() const {
  savme_kernel *k = nullptr;
  check(savme_builder_build(get(), &k));
  return kernel(k);
}

} // namespace savme

#endif
