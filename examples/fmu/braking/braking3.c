/*
 * braking3: the braking model (model.c) as an FMI 3.0 co-simulation FMU, in plain C against the
 * standard's C API. The types and function signatures below are those of the standard's
 * fmi3PlatformTypes.h / fmi3FunctionTypes.h (FMI 3.0), written out for the functions defined.
 *
 * What differs from the FMI 2.0 version (braking.c):
 * - resourcePath is a plain directory path (with a trailing separator), not a file:// URI;
 * - the logger is fmi3LogMessageCallback (not variadic);
 * - the experiment's tolerance comes with fmi3EnterInitializationMode;
 * - `steps` is a UInt32, `road` an Enumeration set through fmi3SetInt64;
 * - once the car has driven `map_length`, fmi3DoStep completes the step and sets
 *   terminateSimulation (FMI 3.0's stop request);
 * - when the importer allows early return, fmi3DoStep returns early at the instant the car
 *   reaches the obstacle (an event inside the step: earlyReturn, lastSuccessfulTime).
 *
 * Build (Linux): cc -shared -fPIC -O2 -o braking.so braking3.c -lm
 */
#include <stdbool.h>
#include <stdint.h>

#include "model.c"

typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef void *fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef double fmi3Float64;
typedef float fmi3Float32;
typedef int8_t fmi3Int8;
typedef uint8_t fmi3UInt8;
typedef int16_t fmi3Int16;
typedef uint16_t fmi3UInt16;
typedef int32_t fmi3Int32;
typedef uint32_t fmi3UInt32;
typedef int64_t fmi3Int64;
typedef uint64_t fmi3UInt64;
typedef bool fmi3Boolean;
typedef char fmi3Char;
typedef const fmi3Char *fmi3String;
typedef uint8_t fmi3Byte;
typedef const fmi3Byte *fmi3Binary;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment instanceEnvironment,
                                       fmi3Status status, fmi3String category,
                                       fmi3String message);
typedef void (*fmi3IntermediateUpdateCallback)(
    fmi3InstanceEnvironment instanceEnvironment, fmi3Float64 intermediateUpdateTime,
    fmi3Boolean intermediateVariableSetRequested, fmi3Boolean intermediateVariableGetAllowed,
    fmi3Boolean intermediateStepFinished, fmi3Boolean canReturnEarly,
    fmi3Boolean *earlyReturnRequested, fmi3Float64 *earlyReturnTime);

#define TOKEN "{b7a1e000-5a4e-4b1c-9e11-b7a1c0ffee03}"

/* An FMI 3.0 instance: the model (first member) and the importer's logger. */
typedef struct {
    Model m;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    int early_return_allowed;
} Instance3;

static void emit3(Model *m, int status, const char *category, const char *text) {
    Instance3 *i = (Instance3 *)m;
    if (i->log) i->log(i->env, (fmi3Status)status, category, text);
}

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n,
                                      const fmi3String cats[]) {
    (void)n;
    (void)cats;
    ((Model *)c)->logging = on;
    return fmi3OK;
}

EXPORT fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String name, fmi3String token, fmi3String resourcePath, fmi3Boolean visible,
    fmi3Boolean loggingOn, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
    const fmi3ValueReference required[], size_t nRequired, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance3 *i;
    (void)visible;
    (void)required;
    (void)nRequired;
    (void)intermediateUpdate;
    if (!token || strcmp(token, TOKEN) != 0) {
        if (logMessage)
            logMessage(env, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: wrong instantiationToken");
        return NULL;
    }
    if (eventModeUsed) {
        if (logMessage)
            logMessage(env, fmi3Error, "logStatusError", "this FMU has no event mode");
        return NULL;
    }
    i = calloc(1, sizeof *i);
    if (!i) return NULL;
    i->env = env;
    i->log = logMessage;
    i->early_return_allowed = earlyReturnAllowed;
    i->m.name = strdup(name ? name : "braking3");
    i->m.resources = resourcePath ? strdup(resourcePath) : NULL;
    i->m.emit = emit3;
    i->m.logging = loggingOn;
    defaults(&i->m);
    say(&i->m, ST_OK, "logAll", "instantiated with resources at %s",
        resourcePath ? resourcePath : "(null)");
    return i;
}

EXPORT void fmi3FreeInstance(fmi3Instance c) {
    Model *m = c;
    if (!m) return;
    free(m->name);
    free(m->resources);
    free(c);
}

EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDefined,
                                              fmi3Float64 tol, fmi3Float64 start,
                                              fmi3Boolean stopDefined, fmi3Float64 stop) {
    Model *m = c;
    (void)stopDefined;
    (void)stop;
    if (tolDefined && !(tol > 0)) {
        say(m, ST_ERROR, "logStatusError", "tolerance %g is not positive", tol);
        return fmi3Error;
    }
    m->tolerance_defined = tolDefined;
    m->tolerance = tol;
    m->time = start;
    return fmi3OK;
}

EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    return (fmi3Status)model_initialise(c);
}

EXPORT fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    say(c, ST_ERROR, "logStatusError", "this FMU has no event mode");
    return fmi3Error;
}

EXPORT fmi3Status fmi3Terminate(fmi3Instance c) { ((Model *)c)->terminated = 1; return fmi3OK; }

EXPORT fmi3Status fmi3Reset(fmi3Instance c) {
    defaults(c);
    return fmi3OK;
}

/* One value of each reference: the loops of every getter and setter. */
#define EACH(call)                                                   \
    size_t k;                                                        \
    if (nv != nValues) {                                             \
        say(c, ST_ERROR, "logStatusError", "%s: %zu references, %zu values", call, nv, nValues); \
        return fmi3Error;                                            \
    }                                                                \
    for (k = 0; k < nv; k++)

EXPORT fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                                 fmi3Float64 v[], size_t nValues) {
    int ok;
    EACH("fmi3GetFloat64") {
        v[k] = real_of(c, vr[k], &ok);
        if (!ok) return (fmi3Status)unknown(c, "fmi3GetFloat64", vr[k]);
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                                 const fmi3Float64 v[], size_t nValues) {
    EACH("fmi3SetFloat64") if (set_real(c, "fmi3SetFloat64", vr[k], v[k]) != ST_OK) return fmi3Error;
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                               fmi3Int64 v[], size_t nValues) {
    EACH("fmi3GetInt64") {
        if (vr[k] != VR_ROAD) return (fmi3Status)unknown(c, "fmi3GetInt64", vr[k]);
        v[k] = ((Model *)c)->road;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                               const fmi3Int64 v[], size_t nValues) {
    EACH("fmi3SetInt64") if (set_road(c, "fmi3SetInt64", vr[k], v[k]) != ST_OK) return fmi3Error;
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetUInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                                fmi3UInt32 v[], size_t nValues) {
    EACH("fmi3GetUInt32") {
        if (vr[k] != VR_STEPS) return (fmi3Status)unknown(c, "fmi3GetUInt32", vr[k]);
        v[k] = (fmi3UInt32)((Model *)c)->steps;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                                 fmi3Boolean v[], size_t nValues) {
    EACH("fmi3GetBoolean") {
        if (vr[k] != VR_COLLISION) return (fmi3Status)unknown(c, "fmi3GetBoolean", vr[k]);
        v[k] = ((Model *)c)->collision != 0;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetString(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                                fmi3String v[], size_t nValues) {
    EACH("fmi3GetString") {
        if (vr[k] != VR_DRIVER) return (fmi3Status)unknown(c, "fmi3GetString", vr[k]);
        v[k] = ((Model *)c)->driver;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,
                                const fmi3String v[], size_t nValues) {
    EACH("fmi3SetString") if (set_driver(c, "fmi3SetString", vr[k], v[k]) != ST_OK) return fmi3Error;
    return fmi3OK;
}

/* No variable of these types: every reference is unknown. */
#define NONE(T, name, cv)                                                                  \
    EXPORT fmi3Status name(fmi3Instance c, const fmi3ValueReference vr[], size_t nv,       \
                           cv T v[], size_t nValues) {                                     \
        (void)v;                                                                           \
        (void)nValues;                                                                     \
        return nv ? (fmi3Status)unknown(c, #name, vr[0]) : fmi3OK;                         \
    }
NONE(fmi3Float32, fmi3GetFloat32, )
NONE(fmi3Float32, fmi3SetFloat32, const)
NONE(fmi3Int8, fmi3GetInt8, )
NONE(fmi3Int8, fmi3SetInt8, const)
NONE(fmi3UInt8, fmi3GetUInt8, )
NONE(fmi3UInt8, fmi3SetUInt8, const)
NONE(fmi3Int16, fmi3GetInt16, )
NONE(fmi3Int16, fmi3SetInt16, const)
NONE(fmi3UInt16, fmi3GetUInt16, )
NONE(fmi3UInt16, fmi3SetUInt16, const)
NONE(fmi3Int32, fmi3GetInt32, )
NONE(fmi3Int32, fmi3SetInt32, const)
NONE(fmi3UInt32, fmi3SetUInt32, const)
NONE(fmi3UInt64, fmi3GetUInt64, )
NONE(fmi3UInt64, fmi3SetUInt64, const)
NONE(fmi3Boolean, fmi3SetBoolean, const)

/* Advances by at most h; with early return allowed, stops at the instant the car reaches the
 * obstacle. Sets terminateSimulation once the car has left the map. */
EXPORT fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
                             fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                             fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    Instance3 *i = c;
    Model *m = c;
    int k, n;
    double dt, now = t;
    (void)noSetPrior;
    *eventHandlingNeeded = false;
    *terminateSimulation = false;
    *earlyReturn = false;
    *lastSuccessfulTime = t;
    if (!can_step(m, "fmi3DoStep", h)) return fmi3Error;
    n = substeps(m, h);
    dt = h / n;
    for (k = 0; k < n; k++) {
        double hit = m->v > 0 ? (m->gap - m->x) / m->v : -1;
        if (i->early_return_allowed && !m->collision && hit >= 0 && hit < dt) {
            /* the car reaches the obstacle inside this sub-step: return early there */
            euler(m, now, hit);
            m->x = m->gap;
            m->collision = 1;
            now += hit;
            *earlyReturn = true;
            say(m, ST_OK, "logAll", "early return at t = %g s: the car reached the obstacle", now);
            break;
        }
        euler(m, t + k * dt, dt);
        now = t + (k + 1) * dt;
    }
    if (!*earlyReturn) now = t + h;
    m->time = now;
    *lastSuccessfulTime = now;
    if (left_map(m, now)) *terminateSimulation = true;
    return fmi3OK;
}

/* Not provided (the model description says so). */
static fmi3Status unsupported(fmi3Instance c, const char *call) {
    if (c) say(c, ST_ERROR, "logStatusError", "%s is not provided by this FMU", call);
    return fmi3Error;
}
EXPORT fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) { (void)s; return unsupported(c, "fmi3GetFMUState"); }
EXPORT fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) { (void)s; return unsupported(c, "fmi3SetFMUState"); }
EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) { (void)s; return unsupported(c, "fmi3FreeFMUState"); }
EXPORT fmi3Status fmi3EnterStepMode(fmi3Instance c) { return unsupported(c, "fmi3EnterStepMode"); }

/* The rest of the FMI 3.0 API, which importers such as FMPy bind when they load the library:
 * model exchange, scheduled execution, clocks, configuration mode, derivatives, serialisation.
 * This FMU declares none of them (no ModelExchange / ScheduledExecution element, every
 * capability flag false, no clocks), so an importer never calls them; each logs and fails if
 * one does. Declared with the instance argument only: the rest is never read. */
#define NOT_PROVIDED(name) \
    EXPORT fmi3Status name(fmi3Instance c) { return unsupported(c, #name); }
NOT_PROVIDED(fmi3ActivateModelPartition)
NOT_PROVIDED(fmi3CompletedIntegratorStep)
NOT_PROVIDED(fmi3DeserializeFMUState)
NOT_PROVIDED(fmi3EnterConfigurationMode)
NOT_PROVIDED(fmi3EnterContinuousTimeMode)
NOT_PROVIDED(fmi3EvaluateDiscreteStates)
NOT_PROVIDED(fmi3ExitConfigurationMode)
NOT_PROVIDED(fmi3GetAdjointDerivative)
NOT_PROVIDED(fmi3GetBinary)
NOT_PROVIDED(fmi3GetClock)
NOT_PROVIDED(fmi3GetContinuousStateDerivatives)
NOT_PROVIDED(fmi3GetContinuousStates)
NOT_PROVIDED(fmi3GetDirectionalDerivative)
NOT_PROVIDED(fmi3GetEventIndicators)
NOT_PROVIDED(fmi3GetIntervalDecimal)
NOT_PROVIDED(fmi3GetIntervalFraction)
NOT_PROVIDED(fmi3GetNominalsOfContinuousStates)
NOT_PROVIDED(fmi3GetNumberOfContinuousStates)
NOT_PROVIDED(fmi3GetNumberOfEventIndicators)
NOT_PROVIDED(fmi3GetNumberOfVariableDependencies)
NOT_PROVIDED(fmi3GetOutputDerivatives)
NOT_PROVIDED(fmi3GetShiftDecimal)
NOT_PROVIDED(fmi3GetShiftFraction)
NOT_PROVIDED(fmi3GetVariableDependencies)
NOT_PROVIDED(fmi3SerializeFMUState)
NOT_PROVIDED(fmi3SerializedFMUStateSize)
NOT_PROVIDED(fmi3SetBinary)
NOT_PROVIDED(fmi3SetClock)
NOT_PROVIDED(fmi3SetContinuousStates)
NOT_PROVIDED(fmi3SetIntervalDecimal)
NOT_PROVIDED(fmi3SetIntervalFraction)
NOT_PROVIDED(fmi3SetShiftDecimal)
NOT_PROVIDED(fmi3SetShiftFraction)
NOT_PROVIDED(fmi3SetTime)
NOT_PROVIDED(fmi3UpdateDiscreteStates)

/* Model exchange and scheduled execution: not provided, no instance. */
EXPORT fmi3Instance fmi3InstantiateModelExchange(void) { return NULL; }
EXPORT fmi3Instance fmi3InstantiateScheduledExecution(void) { return NULL; }
