/*
 * stairs: a test FMU with the behaviours of third-party FMUs that changed savme's verdicts
 * (issue 26), exporting both the FMI 2.0 and the FMI 3.0 co-simulation C API (the model
 * description packed with it picks one; the typedefs are those of the standards' headers).
 *
 *   x(t) = x0 + rate * t + jump * events(t),   failed = x >= threshold,
 *
 * where events(t) counts the instants k * period (k = 1, 2, ...) passed; `steps` counts the
 * doStep calls that advanced time. Its quirks:
 * - a failure at t = 0: x0 >= threshold;
 * - FMI 3.0 early return (when the importer allows it) at each event instant strictly inside
 *   a step, computed as k * period: on a grid of accumulated t + h, an event lands a few ulps
 *   before the communication point; a doStep below `min_step` seconds is refused (fmi3Error);
 * - `stop_at_failure`: the FMU ends the simulation at the instant x reaches the threshold:
 *   FMI 2.0 fmi2Discard with fmi2Terminated and fmi2LastSuccessfulTime at that instant, FMI 3.0
 *   terminateSimulation (with an early return there when allowed); the state is the one at
 *   that instant (failed = true);
 * - its reset does not clear that stop request (as some widely used FMUs do): an instance
 *   reset after one refuses every later step (fmi2Discard / terminateSimulation at once).
 * FMI 3.0 only (issue 40):
 * - integers exact to the last bit: `failed` also holds when the Int64 parameter `ticket` or
 *   the UInt64 parameter `seed` is odd (9007199254740993 is odd, its nearest double is not);
 * - a structural parameter `stages` (UInt64, default 1) multiplying the rate, settable only in
 *   configuration mode (fmi3EnterConfigurationMode / fmi3ExitConfigurationMode) or in the
 *   Instantiated state (initial="exact", where FMPy sets it); the Int32 output
 *   `configurations` counts the configuration modes left since instantiation or reset.
 * With the environment variable SAVME_STAIRS_CRASH set, instantiation dies of a genuine
 * SIGSEGV (a write through a null pointer): a library that crashes in its instantiate.
 *
 * Build (Linux): cc -shared -fPIC -O2 -o stairs.so stairs.c -lm
 */
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EXPORT __attribute__((visibility("default")))

enum { VR_X0, VR_RATE, VR_THRESHOLD, VR_PERIOD, VR_JUMP, VR_MIN_STEP, VR_STOP, VR_X, VR_FAILED,
       VR_STEPS, VR_EVENTS, VR_TIME, VR_SEED, VR_TICKET, VR_STAGES, VR_CONFIGURATIONS };

typedef struct {
    double x0, rate, threshold, period, jump, min_step;
    int stop_at_failure;
    double time, x;
    int steps, events, failed;
    int stop_requested; /* deliberately kept by reset */
    uint64_t seed;      /* an FMI 3.0 UInt64 parameter: odd fails */
    int64_t ticket;     /* an FMI 3.0 Int64 parameter: odd fails */
    uint64_t stages;    /* an FMI 3.0 structural parameter: the rate's factor */
    int configuring;    /* in configuration mode */
    int instantiated;   /* in the Instantiated state (before initialisation) */
    int configurations; /* configuration modes left */
    int early_return_allowed;
    /* FMI 2.0 or 3.0 logger, called as log3(env, status, category, message) or
     * log2(env, name, status, category, "%s", message) */
    void *env;
    void (*log2)(void *, const char *, int, const char *, const char *, ...);
    void (*log3)(void *, int, const char *, const char *);
} Model;

/* Dies of SIGSEGV when SAVME_STAIRS_CRASH is set (see above). */
static void crash_if_asked(void) {
    if (getenv("SAVME_STAIRS_CRASH")) *(volatile int *)0 = 0;
}

static void say(Model *m, int status, const char *fmt, ...) {
    char text[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    if (m->log3) m->log3(m->env, status, "logStatusError", text);
    else if (m->log2) m->log2(m->env, "stairs", status, "logStatusError", "%s", text);
}

static void defaults(Model *m) {
    m->x0 = 0;
    m->rate = 1;
    m->threshold = 5;
    m->period = 0;
    m->jump = 0;
    m->min_step = 1e-9;
    m->stop_at_failure = 0;
    m->seed = 0;
    m->ticket = 0;
    m->stages = 1;
    m->configuring = 0;
    m->instantiated = 1;
    m->configurations = 0;
    m->time = 0;
    m->steps = 0;
    m->events = 0;
    m->failed = 0;
    m->x = 0;
}

/* dx/dt: the rate times the structural parameter `stages`. */
static double slope(const Model *m) { return m->rate * (double)m->stages; }

static void evaluate(Model *m) {
    m->x = m->x0 + slope(m) * m->time + m->jump * m->events;
    m->failed = m->x >= m->threshold || (m->ticket & 1) || (m->seed & 1);
}

static int set_real(Model *m, unsigned vr, double v) {
    switch (vr) {
    case VR_X0: m->x0 = v; break;
    /* x's start value, when the model description declares one (initial="exact"): x0 */
    case VR_X: m->x0 = v; break;
    case VR_RATE: m->rate = v; break;
    case VR_THRESHOLD: m->threshold = v; break;
    case VR_PERIOD: m->period = v; break;
    case VR_JUMP: m->jump = v; break;
    case VR_MIN_STEP: m->min_step = v; break;
    default: say(m, 3, "no Real variable with value reference %u to set", vr); return 0;
    }
    return 1;
}

static int get_real(Model *m, unsigned vr, double *v) {
    switch (vr) {
    case VR_X0: *v = m->x0; break;
    case VR_RATE: *v = m->rate; break;
    case VR_THRESHOLD: *v = m->threshold; break;
    case VR_PERIOD: *v = m->period; break;
    case VR_JUMP: *v = m->jump; break;
    case VR_MIN_STEP: *v = m->min_step; break;
    case VR_X: *v = m->x; break;
    case VR_TIME: *v = m->time; break;
    default: say(m, 3, "no Real variable with value reference %u", vr); return 0;
    }
    return 1;
}

static int get_int(Model *m, unsigned vr, int *v) {
    if (vr == VR_STEPS) *v = m->steps;
    else if (vr == VR_EVENTS) *v = m->events;
    else if (vr == VR_CONFIGURATIONS) *v = m->configurations;
    else { say(m, 3, "no Integer variable with value reference %u", vr); return 0; }
    return 1;
}

/* How one doStep ended. */
enum { DONE, EARLY, STOPPED, REFUSED, BAD };

/* One step from t by h (the instance's time must be t); *reached is where the FMU is after.
 * `early_allowed`: may return early at an event; `stop_inside`: may stop inside the step at the
 * failure (FMI 2.0 discard, FMI 3.0 early return). */
static int step(Model *m, double t, double h, int early_allowed, int stop_inside, double *reached) {
    double end = t + h, next;
    *reached = m->time;
    if (m->stop_requested) return REFUSED;
    if (!(h >= m->min_step)) {
        say(m, 3, "doStep(%.17g, %.17g): step below the minimum step %g", t, h, m->min_step);
        return BAD;
    }
    if (fabs(t - m->time) > 1e-9 * fmax(1.0, fabs(t))) {
        say(m, 3, "doStep at %.17g, but the FMU is at %.17g", t, m->time);
        return BAD;
    }
    m->steps++;
    if (stop_inside && m->stop_at_failure && !m->failed && slope(m) > 0 && m->jump == 0) {
        double cross = t + (m->threshold - (m->x0 + slope(m) * t)) / slope(m);
        if (cross > t && cross < end) {
            m->time = cross;
            m->x = m->threshold;
            m->failed = 1;
            m->stop_requested = 1;
            *reached = cross;
            return STOPPED;
        }
    }
    next = m->period > 0 ? (m->events + 1) * m->period : INFINITY;
    if (early_allowed && next > t && next < end) {
        m->events++;
        m->time = next;
        evaluate(m);
        *reached = next;
        return EARLY;
    }
    while (next <= end) {
        m->events++;
        next = (m->events + 1) * m->period;
    }
    m->time = end;
    evaluate(m);
    *reached = end;
    if (m->stop_at_failure && m->failed) {
        m->stop_requested = 1;
        return STOPPED;
    }
    return DONE;
}

/* ---------------------------------------------------------------- FMI 2.0 */

typedef unsigned int fmi2ValueReference;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated } fmi2StatusKind;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, fmi2Status);
    void *componentEnvironment;
} fmi2CallbackFunctions;

#define GUID2 "{57a125e0-0000-4000-8000-5ba125c0ffee}"

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

EXPORT void *fmi2Instantiate(const char *name, int type, const char *guid, const char *res,
                             const fmi2CallbackFunctions *cb, int visible, int loggingOn) {
    Model *m;
    (void)name; (void)res; (void)visible; (void)loggingOn;
    crash_if_asked();
    if (type != 1 || !guid || strcmp(guid, GUID2) != 0 || !cb) return NULL;
    m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->env = cb->componentEnvironment;
    m->log2 = cb->logger;
    defaults(m);
    return m;
}

EXPORT void fmi2FreeInstance(void *c) { free(c); }
EXPORT fmi2Status fmi2SetDebugLogging(void *c, int on, size_t n, const char *cats[]) {
    (void)c; (void)on; (void)n; (void)cats;
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetupExperiment(void *c, int tolDefined, double tol, double start,
                                      int stopDefined, double stop) {
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stop;
    ((Model *)c)->time = start;
    return fmi2OK;
}
EXPORT fmi2Status fmi2EnterInitializationMode(void *c) { (void)c; return fmi2OK; }
EXPORT fmi2Status fmi2ExitInitializationMode(void *c) { evaluate(c); return fmi2OK; }
EXPORT fmi2Status fmi2Terminate(void *c) { (void)c; return fmi2OK; }
/* The quirk: the stop request survives the reset. */
EXPORT fmi2Status fmi2Reset(void *c) { defaults(c); return fmi2OK; }

EXPORT fmi2Status fmi2GetReal(void *c, const fmi2ValueReference vr[], size_t n, double v[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!get_real(c, vr[i], &v[i])) return fmi2Error;
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetReal(void *c, const fmi2ValueReference vr[], size_t n, const double v[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!set_real(c, vr[i], v[i])) return fmi2Error;
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetInteger(void *c, const fmi2ValueReference vr[], size_t n, int v[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!get_int(c, vr[i], &v[i])) return fmi2Error;
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetInteger(void *c, const fmi2ValueReference vr[], size_t n, const int v[]) {
    (void)v;
    if (n) { say(c, 3, "no settable Integer variable %u", vr[0]); return fmi2Error; }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetBoolean(void *c, const fmi2ValueReference vr[], size_t n, int v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] == VR_FAILED) v[i] = m->failed;
        else if (vr[i] == VR_STOP) v[i] = m->stop_at_failure;
        else { say(m, 3, "no Boolean variable %u", vr[i]); return fmi2Error; }
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetBoolean(void *c, const fmi2ValueReference vr[], size_t n, const int v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_STOP) { say(m, 3, "no settable Boolean variable %u", vr[i]); return fmi2Error; }
        m->stop_at_failure = v[i] != 0;
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetString(void *c, const fmi2ValueReference vr[], size_t n, const char *v[]) {
    (void)v;
    if (n) { say(c, 3, "no String variable %u", vr[0]); return fmi2Error; }
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetString(void *c, const fmi2ValueReference vr[], size_t n, const char *v[]) {
    (void)v;
    if (n) { say(c, 3, "no String variable %u", vr[0]); return fmi2Error; }
    return fmi2OK;
}

EXPORT fmi2Status fmi2DoStep(void *c, double t, double h, int noSetPrior) {
    double reached;
    (void)noSetPrior;
    switch (step(c, t, h, 0, 1, &reached)) {
    case DONE: return fmi2OK;
    case STOPPED:
    case REFUSED: return fmi2Discard;
    default: return fmi2Error;
    }
}
EXPORT fmi2Status fmi2CancelStep(void *c) { (void)c; return fmi2Error; }
EXPORT fmi2Status fmi2GetStatus(void *c, int s, fmi2Status *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetRealStatus(void *c, int s, double *v) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = ((Model *)c)->time;
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetIntegerStatus(void *c, int s, int *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetBooleanStatus(void *c, int s, int *v) {
    if (s != fmi2Terminated) return fmi2Discard;
    *v = ((Model *)c)->stop_requested;
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetStringStatus(void *c, int s, const char **v) { (void)c; (void)s; (void)v; return fmi2Discard; }

/* The rest of the FMI 2.0 API, bound by importers such as FMPy; not provided. */
#define NOT_PROVIDED2(name) \
    EXPORT fmi2Status name(void *c) { say(c, 3, #name " is not provided"); return fmi2Error; }
NOT_PROVIDED2(fmi2GetFMUstate)
NOT_PROVIDED2(fmi2SetFMUstate)
NOT_PROVIDED2(fmi2FreeFMUstate)
NOT_PROVIDED2(fmi2SerializedFMUstateSize)
NOT_PROVIDED2(fmi2SerializeFMUstate)
NOT_PROVIDED2(fmi2DeSerializeFMUstate)
NOT_PROVIDED2(fmi2GetDirectionalDerivative)
NOT_PROVIDED2(fmi2SetRealInputDerivatives)
NOT_PROVIDED2(fmi2GetRealOutputDerivatives)

/* ---------------------------------------------------------------- FMI 3.0 */

typedef uint32_t fmi3ValueReference;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;

#define TOKEN3 "{57a125e0-0000-4000-8000-5ba125c0ff33}"

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }
EXPORT fmi3Status fmi3SetDebugLogging(void *c, bool on, size_t n, const char *cats[]) {
    (void)c; (void)on; (void)n; (void)cats;
    return fmi3OK;
}

EXPORT void *fmi3InstantiateCoSimulation(const char *name, const char *token, const char *res,
                                         bool visible, bool loggingOn, bool eventModeUsed,
                                         bool earlyReturnAllowed, const fmi3ValueReference req[],
                                         size_t nReq, void *env,
                                         void (*logMessage)(void *, int, const char *, const char *),
                                         void *intermediateUpdate) {
    Model *m;
    (void)name; (void)res; (void)visible; (void)loggingOn; (void)req; (void)nReq;
    (void)intermediateUpdate;
    crash_if_asked();
    if (!token || strcmp(token, TOKEN3) != 0 || eventModeUsed) return NULL;
    m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->env = env;
    m->log3 = logMessage;
    m->early_return_allowed = earlyReturnAllowed;
    defaults(m);
    return m;
}

EXPORT void fmi3FreeInstance(void *c) { free(c); }
EXPORT fmi3Status fmi3EnterInitializationMode(void *c, bool tolDefined, double tol, double start,
                                              bool stopDefined, double stop) {
    Model *m = c;
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stop;
    if (m->configuring) { say(m, 3, "fmi3EnterInitializationMode in configuration mode"); return fmi3Error; }
    m->time = start;
    m->instantiated = 0;
    return fmi3OK;
}
EXPORT fmi3Status fmi3EnterConfigurationMode(void *c) {
    Model *m = c;
    if (!m->instantiated || m->configuring) {
        say(m, 3, "fmi3EnterConfigurationMode outside the Instantiated state");
        return fmi3Error;
    }
    m->configuring = 1;
    return fmi3OK;
}
EXPORT fmi3Status fmi3ExitConfigurationMode(void *c) {
    Model *m = c;
    if (!m->configuring) { say(m, 3, "fmi3ExitConfigurationMode outside configuration mode"); return fmi3Error; }
    m->configuring = 0;
    m->configurations++;
    return fmi3OK;
}
EXPORT fmi3Status fmi3ExitInitializationMode(void *c) { evaluate(c); return fmi3OK; }
EXPORT fmi3Status fmi3Terminate(void *c) { (void)c; return fmi3OK; }
/* The quirk: the stop request survives the reset. */
EXPORT fmi3Status fmi3Reset(void *c) { defaults(c); return fmi3OK; }

#define EACH3                                                        \
    size_t k;                                                        \
    if (nv != nValues) return fmi3Error;                             \
    for (k = 0; k < nv; k++)

EXPORT fmi3Status fmi3GetFloat64(void *c, const fmi3ValueReference vr[], size_t nv, double v[], size_t nValues) {
    EACH3 if (!get_real(c, vr[k], &v[k])) return fmi3Error;
    return fmi3OK;
}
EXPORT fmi3Status fmi3SetFloat64(void *c, const fmi3ValueReference vr[], size_t nv, const double v[], size_t nValues) {
    EACH3 if (!set_real(c, vr[k], v[k])) return fmi3Error;
    return fmi3OK;
}
EXPORT fmi3Status fmi3GetInt32(void *c, const fmi3ValueReference vr[], size_t nv, int32_t v[], size_t nValues) {
    EACH3 {
        int i;
        if (!get_int(c, vr[k], &i)) return fmi3Error;
        v[k] = i;
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3GetBoolean(void *c, const fmi3ValueReference vr[], size_t nv, bool v[], size_t nValues) {
    Model *m = c;
    EACH3 {
        if (vr[k] == VR_FAILED) v[k] = m->failed;
        else if (vr[k] == VR_STOP) v[k] = m->stop_at_failure;
        else return fmi3Error;
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3SetBoolean(void *c, const fmi3ValueReference vr[], size_t nv, const bool v[], size_t nValues) {
    Model *m = c;
    EACH3 {
        if (vr[k] != VR_STOP) return fmi3Error;
        m->stop_at_failure = v[k];
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3DoStep(void *c, double t, double h, bool noSetPrior, bool *eventHandlingNeeded,
                             bool *terminateSimulation, bool *earlyReturn, double *lastSuccessfulTime) {
    Model *m = c;
    int r;
    (void)noSetPrior;
    *eventHandlingNeeded = false;
    r = step(m, t, h, m->early_return_allowed, m->early_return_allowed, lastSuccessfulTime);
    *terminateSimulation = r == STOPPED || r == REFUSED;
    *earlyReturn = m->early_return_allowed && (r == EARLY || ((r == STOPPED || r == REFUSED) && *lastSuccessfulTime < t + h));
    return r == BAD ? fmi3Error : fmi3OK;
}

/* `events` read as an Int64 (an Enumeration output, when the model description says so),
 * and `ticket`. */
EXPORT fmi3Status fmi3GetInt64(void *c, const fmi3ValueReference vr[], size_t nv, int64_t v[], size_t nValues) {
    Model *m = c;
    EACH3 {
        if (vr[k] == VR_EVENTS) v[k] = m->events;
        else if (vr[k] == VR_TICKET) v[k] = m->ticket;
        else return fmi3Error;
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3SetInt64(void *c, const fmi3ValueReference vr[], size_t nv, const int64_t v[], size_t nValues) {
    Model *m = c;
    EACH3 {
        if (vr[k] != VR_TICKET) { say(m, 3, "no settable Int64 variable %u", vr[k]); return fmi3Error; }
        m->ticket = v[k];
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3GetUInt64(void *c, const fmi3ValueReference vr[], size_t nv, uint64_t v[], size_t nValues) {
    Model *m = c;
    EACH3 {
        if (vr[k] == VR_SEED) v[k] = m->seed;
        else if (vr[k] == VR_STAGES) v[k] = m->stages;
        else return fmi3Error;
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3SetUInt64(void *c, const fmi3ValueReference vr[], size_t nv, const uint64_t v[], size_t nValues) {
    Model *m = c;
    EACH3 {
        if (vr[k] == VR_SEED) m->seed = v[k];
        else if (vr[k] == VR_STAGES) {
            /* A structural parameter: in configuration mode, or before initialisation. */
            if (!m->configuring && !m->instantiated) {
                say(m, 3, "the structural parameter `stages` is set after initialisation");
                return fmi3Error;
            }
            m->stages = v[k];
        } else return fmi3Error;
    }
    return fmi3OK;
}

/* The rest of the FMI 3.0 API, bound by importers such as FMPy; not provided. */
#define NOT_PROVIDED3(name) \
    EXPORT fmi3Status name(void *c) { if (c) say(c, 3, #name " is not provided"); return fmi3Error; }
NOT_PROVIDED3(fmi3GetFloat32) NOT_PROVIDED3(fmi3SetFloat32)
NOT_PROVIDED3(fmi3GetInt8) NOT_PROVIDED3(fmi3SetInt8)
NOT_PROVIDED3(fmi3GetUInt8) NOT_PROVIDED3(fmi3SetUInt8)
NOT_PROVIDED3(fmi3GetInt16) NOT_PROVIDED3(fmi3SetInt16)
NOT_PROVIDED3(fmi3GetUInt16) NOT_PROVIDED3(fmi3SetUInt16)
NOT_PROVIDED3(fmi3SetInt32)
NOT_PROVIDED3(fmi3GetUInt32) NOT_PROVIDED3(fmi3SetUInt32)
NOT_PROVIDED3(fmi3GetString) NOT_PROVIDED3(fmi3SetString)
NOT_PROVIDED3(fmi3GetBinary) NOT_PROVIDED3(fmi3SetBinary)
NOT_PROVIDED3(fmi3GetClock) NOT_PROVIDED3(fmi3SetClock)
NOT_PROVIDED3(fmi3GetFMUState) NOT_PROVIDED3(fmi3SetFMUState) NOT_PROVIDED3(fmi3FreeFMUState)
NOT_PROVIDED3(fmi3EnterStepMode) NOT_PROVIDED3(fmi3EnterEventMode)
NOT_PROVIDED3(fmi3ActivateModelPartition)
NOT_PROVIDED3(fmi3CompletedIntegratorStep)
NOT_PROVIDED3(fmi3DeserializeFMUState)
NOT_PROVIDED3(fmi3EnterContinuousTimeMode)
NOT_PROVIDED3(fmi3EvaluateDiscreteStates)
NOT_PROVIDED3(fmi3GetAdjointDerivative)
NOT_PROVIDED3(fmi3GetContinuousStateDerivatives)
NOT_PROVIDED3(fmi3GetContinuousStates)
NOT_PROVIDED3(fmi3GetDirectionalDerivative)
NOT_PROVIDED3(fmi3GetEventIndicators)
NOT_PROVIDED3(fmi3GetIntervalDecimal)
NOT_PROVIDED3(fmi3GetIntervalFraction)
NOT_PROVIDED3(fmi3GetNominalsOfContinuousStates)
NOT_PROVIDED3(fmi3GetNumberOfContinuousStates)
NOT_PROVIDED3(fmi3GetNumberOfEventIndicators)
NOT_PROVIDED3(fmi3GetNumberOfVariableDependencies)
NOT_PROVIDED3(fmi3GetOutputDerivatives)
NOT_PROVIDED3(fmi3GetShiftDecimal)
NOT_PROVIDED3(fmi3GetShiftFraction)
NOT_PROVIDED3(fmi3GetVariableDependencies)
NOT_PROVIDED3(fmi3SerializeFMUState)
NOT_PROVIDED3(fmi3SerializedFMUStateSize)
NOT_PROVIDED3(fmi3SetContinuousStates)
NOT_PROVIDED3(fmi3SetIntervalDecimal)
NOT_PROVIDED3(fmi3SetIntervalFraction)
NOT_PROVIDED3(fmi3SetShiftDecimal)
NOT_PROVIDED3(fmi3SetShiftFraction)
NOT_PROVIDED3(fmi3SetTime)
NOT_PROVIDED3(fmi3UpdateDiscreteStates)
EXPORT void *fmi3InstantiateModelExchange(void) { return NULL; }
EXPORT void *fmi3InstantiateScheduledExecution(void) { return NULL; }
