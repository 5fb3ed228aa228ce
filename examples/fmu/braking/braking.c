/*
 * braking: an FMI 2.0 co-simulation FMU written the way vendors write them, in plain C
 * against the standard's C API (the typedefs below are those of fmi2FunctionTypes.h); the
 * model itself is model.c, shared with the FMI 3.0 version braking3.c.
 *
 * Outputs: distance (m), speed (m/s), collision (distance reached 0 while moving), steps (Euler
 * steps taken: the work). When `map_length` > 0 and the car has driven that far, fmi2DoStep
 * returns fmi2Discard and fmi2GetBooleanStatus(fmi2Terminated) says true: the FMU asks to end
 * the simulation. Messages go through the environment's logger (printf-style, with arguments).
 *
 * Build (Linux): cc -shared -fPIC -O2 -o braking.so braking.c -lm
 */
#include "model.c"

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum {
    fmi2DoStepStatus,
    fmi2PendingStatus,
    fmi2LastSuccessfulTime,
    fmi2Terminated
} fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String,
                                   fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define GUID "{b7a1e000-5a4e-4b1c-9e11-b7a1c0ffee02}"

/* The FMI 2.0 importer's callbacks of an instance (the Model is its first member). */
typedef struct {
    Model m;
    fmi2CallbackFunctions cb;
} Instance2;

static void emit2(Model *m, int status, const char *category, const char *text) {
    Instance2 *i = (Instance2 *)m;
    /* the logger is printf-like: pass the text as an argument, never as the format */
    if (i->cb.logger)
        i->cb.logger(i->cb.componentEnvironment, m->name, (fmi2Status)status, category, "%s", text);
}

/* file:///a%20b/resources -> /a b/resources (NULL if not a file URI) */
static char *uri_to_path(const char *uri) {
    const char *p;
    char *out, *o;
    if (!uri || strncmp(uri, "file:", 5) != 0) return NULL;
    p = uri + 5;
    if (strncmp(p, "///", 3) == 0) p += 2;
    else if (strncmp(p, "//localhost/", 12) == 0) p += 11;
    out = o = malloc(strlen(p) + 1);
    if (!out) return NULL;
    while (*p) {
        if (p[0] == '%' && isxdigit((unsigned char)p[1]) && isxdigit((unsigned char)p[2])) {
            char hex[3] = {p[1], p[2], 0};
            *o++ = (char)strtol(hex, NULL, 16);
            p += 3;
        } else {
            *o++ = *p++;
        }
    }
    *o = 0;
    return out;
}

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

#ifdef BRAKING_ONLY_ONCE
/* Built with -DBRAKING_ONLY_ONCE (savme's tests): one instance per process at a time, as its
 * model description then declares (canBeInstantiatedOnlyOncePerProcess="true"). */
static int live_instances = 0;
#endif

EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                                     fmi2String resources, const fmi2CallbackFunctions *cb,
                                     fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance2 *i;
    (void)visible;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0 || !cb) return NULL;
#ifdef BRAKING_ONLY_ONCE
    if (live_instances > 0) {
        if (cb->logger)
            cb->logger(cb->componentEnvironment, name, fmi2Error, "logStatusError",
                       "an instance is alive: this FMU can be instantiated only once per process");
        return NULL;
    }
    live_instances++;
#endif
    i = calloc(1, sizeof *i);
    if (!i) return NULL;
    i->cb = *cb;
    i->m.name = strdup(name ? name : "braking");
    i->m.resources = uri_to_path(resources);
    i->m.emit = emit2;
    i->m.logging = loggingOn;
    defaults(&i->m);
    say(&i->m, ST_OK, "logAll", "instantiated with resources at %s", resources ? resources : "(null)");
    return i;
}

EXPORT void fmi2FreeInstance(fmi2Component c) {
    Model *m = c;
    if (!m) return;
#ifdef BRAKING_ONLY_ONCE
    live_instances--;
#endif
    free(m->name);
    free(m->resources);
    free(c);
}

EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                                      const fmi2String cats[]) {
    (void)n;
    (void)cats;
    ((Model *)c)->logging = on;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol,
                                      fmi2Real start, fmi2Boolean stopDefined, fmi2Real stop) {
    Model *m = c;
    (void)stopDefined;
    (void)stop;
    if (tolDefined && !(tol > 0)) {
        say(m, ST_ERROR, "logStatusError", "tolerance %g is not positive", tol);
        return fmi2Error;
    }
    m->tolerance_defined = tolDefined;
    m->tolerance = tol;
    m->time = start;
    return fmi2OK;
}

EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return (fmi2Status)model_initialise(c);
}

EXPORT fmi2Status fmi2Terminate(fmi2Component c) { ((Model *)c)->terminated = 1; return fmi2OK; }

EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    defaults(c);
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    size_t i;
    int ok;
    for (i = 0; i < n; i++) {
        v[i] = real_of(c, vr[i], &ok);
        if (!ok || vr[i] == VR_TIME) return (fmi2Status)unknown(c, "fmi2GetReal", vr[i]);
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] == VR_ROAD) v[i] = m->road;
        else if (vr[i] == VR_STEPS) v[i] = m->steps;
        else return (fmi2Status)unknown(m, "fmi2GetInteger", vr[i]);
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_COLLISION) return (fmi2Status)unknown(m, "fmi2GetBoolean", vr[i]);
        v[i] = m->collision;
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_DRIVER) return (fmi2Status)unknown(m, "fmi2GetString", vr[i]);
        v[i] = m->driver;
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (set_real(c, "fmi2SetReal", vr[i], v[i]) != ST_OK) return fmi2Error;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (set_road(c, "fmi2SetInteger", vr[i], v[i]) != ST_OK) return fmi2Error;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)v;
    return n ? (fmi2Status)not_now(c, "fmi2SetBoolean", vr[0]) : fmi2OK;
}

EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (set_driver(c, "fmi2SetString", vr[i], v[i]) != ST_OK) return fmi2Error;
    return fmi2OK;
}

/* When the car has left the map, the next step is refused with fmi2Discard and
 * fmi2GetBooleanStatus(fmi2Terminated) says true: the FMU asks to end the simulation. */
EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Model *m = c;
    int k, n;
    (void)noSetPrior;
    if (!can_step(m, "fmi2DoStep", h)) return fmi2Error;
    if (left_map(m, t)) return fmi2Discard;
    n = substeps(m, h);
    for (k = 0; k < n; k++) euler(m, t + k * h / n, h / n);
    m->time = t + h;
    return fmi2OK;
}

EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }

EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}

EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = ((Model *)c)->time;
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}

EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    if (s != fmi2Terminated) return fmi2Discard;
    *v = ((Model *)c)->terminated;
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}

/* Not provided (the model description says so). */
static fmi2Status unsupported(fmi2Component c, const char *call) {
    if (c) say(c, fmi2Error, "logStatusError", "%s is not provided by this FMU", call);
    return fmi2Error;
}
EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)s; return unsupported(c, "fmi2GetFMUstate"); }
EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)s; return unsupported(c, "fmi2SetFMUstate"); }
EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)s; return unsupported(c, "fmi2FreeFMUstate"); }
EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { (void)s; (void)n; return unsupported(c, "fmi2SerializedFMUstateSize"); }
EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { (void)s; (void)b; (void)n; return unsupported(c, "fmi2SerializeFMUstate"); }
EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) { (void)s; (void)b; (void)n; return unsupported(c, "fmi2DeSerializeFMUstate"); }
EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference a[], size_t na, const fmi2ValueReference b[], size_t nb, const fmi2Real dv[], fmi2Real r[]) { (void)a; (void)na; (void)b; (void)nb; (void)dv; (void)r; return unsupported(c, "fmi2GetDirectionalDerivative"); }
EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]) { (void)vr; (void)n; (void)o; (void)v; return unsupported(c, "fmi2SetRealInputDerivatives"); }
EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]) { (void)vr; (void)n; (void)o; (void)v; return unsupported(c, "fmi2GetRealOutputDerivatives"); }
