/*
 * braking: an FMI 2.0 co-simulation FMU written the way vendors write them, in plain C
 * against the standard's C API (the typedefs below are those of fmi2FunctionTypes.h).
 *
 * A car at `speed0` approaches a stopped obstacle `gap` metres ahead; the driver reacts after a
 * reaction time (String parameter `driver`: "alert" 0.8 s, "distracted" 1.6 s) and brakes with
 * friction * 9.81 m/s^2, the friction of the `road` (Enumeration dry/wet/ice) read from
 * resources/friction.txt during initialisation. The state is integrated with explicit Euler at
 * the communication step — or, when fmi2SetupExperiment gives a tolerance, in sub-steps of at
 * most `tolerance` seconds — so the step size and the tolerance are its fidelity. It has no
 * fidelity parameter of its own.
 *
 * Outputs: distance (m), speed (m/s), collision (distance reached 0 while moving), steps (Euler
 * steps taken: the work). When `map_length` > 0 and the car has driven that far, fmi2DoStep
 * returns fmi2Discard and fmi2GetBooleanStatus(fmi2Terminated) says true: the FMU asks to end
 * the simulation. Messages go through the environment's logger (printf-style, with arguments).
 *
 * Build (Linux): cc -shared -fPIC -O2 -o braking.so braking.c -lm
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

#define EXPORT __attribute__((visibility("default")))
#define GUID "{b7a1e000-5a4e-4b1c-9e11-b7a1c0ffee02}"

enum { VR_SPEED0, VR_GAP, VR_ROAD, VR_DRIVER, VR_MAP_LENGTH, VR_DISTANCE, VR_SPEED,
       VR_COLLISION, VR_STEPS, VR_FRICTION };

typedef struct {
    char *name;
    char *resources; /* a directory path, decoded from the file:// URI */
    fmi2CallbackFunctions cb;
    int logging;
    /* parameters */
    double speed0, gap, map_length;
    int road;
    char driver[64];
    /* set up */
    double tolerance;
    int tolerance_defined;
    /* state */
    int initialised, terminated;
    double time, x, v, friction, reaction;
    int collision, steps;
} Model;

static void say(Model *m, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[1024];
    va_list ap;
    if (status == fmi2OK && !m->logging) return;
    if (!m->cb.logger) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* the logger is printf-like: pass the text as an argument, never as the format */
    m->cb.logger(m->cb.componentEnvironment, m->name, status, category, "%s", buf);
}

static void defaults(Model *m) {
    m->speed0 = 15.0;
    m->gap = 40.0;
    m->map_length = 0.0;
    m->road = 1;
    strcpy(m->driver, "alert");
    m->tolerance_defined = 0;
    m->initialised = m->terminated = 0;
    m->time = m->x = m->v = m->friction = m->reaction = 0.0;
    m->collision = m->steps = 0;
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

EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                                     fmi2String resources, const fmi2CallbackFunctions *cb,
                                     fmi2Boolean visible, fmi2Boolean loggingOn) {
    Model *m;
    (void)visible;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0 || !cb) return NULL;
    m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->name = strdup(name ? name : "braking");
    m->cb = *cb;
    m->logging = loggingOn;
    m->resources = uri_to_path(resources);
    defaults(m);
    say(m, fmi2OK, "logAll", "instantiated with resources at %s", resources ? resources : "(null)");
    return m;
}

EXPORT void fmi2FreeInstance(fmi2Component c) {
    Model *m = c;
    if (!m) return;
    free(m->name);
    free(m->resources);
    free(m);
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
        say(m, fmi2Error, "logStatusError", "tolerance %g is not positive", tol);
        return fmi2Error;
    }
    m->tolerance_defined = tolDefined;
    m->tolerance = tol;
    m->time = start;
    return fmi2OK;
}

EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

/* The friction of road surface `road` (1 dry, 2 wet, 3 ice) from resources/friction.txt. */
static fmi2Status read_friction(Model *m) {
    static const char *names[] = {"dry", "wet", "ice"};
    char path[4096], line[256], surface[64];
    double mu;
    FILE *f;
    if (m->road < 1 || m->road > 3) {
        say(m, fmi2Error, "logStatusError", "road = %d is not 1 (dry), 2 (wet) or 3 (ice)", m->road);
        return fmi2Error;
    }
    if (!m->resources) {
        say(m, fmi2Error, "logStatusError", "no resource location: cannot read friction.txt");
        return fmi2Error;
    }
    snprintf(path, sizeof path, "%s/friction.txt", m->resources);
    f = fopen(path, "r");
    if (!f) {
        say(m, fmi2Error, "logStatusError", "cannot open %s: %s", path, strerror(errno));
        return fmi2Error;
    }
    while (fgets(line, sizeof line, f)) {
        if (sscanf(line, "%63s %lf", surface, &mu) == 2 && strcmp(surface, names[m->road - 1]) == 0) {
            fclose(f);
            m->friction = mu;
            say(m, fmi2OK, "logAll", "friction %.2f for the %s road from %s", mu, surface, path);
            return fmi2OK;
        }
    }
    fclose(f);
    say(m, fmi2Error, "logStatusError", "%s has no line for the %s road", path, names[m->road - 1]);
    return fmi2Error;
}

EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Model *m = c;
    if (strcmp(m->driver, "alert") == 0) m->reaction = 0.8;
    else if (strcmp(m->driver, "distracted") == 0) m->reaction = 1.6;
    else {
        say(m, fmi2Error, "logStatusError", "unknown driver profile '%s' (expected alert or distracted)",
            m->driver);
        return fmi2Error;
    }
    if (read_friction(m) != fmi2OK) return fmi2Error;
    m->x = 0.0;
    m->v = m->speed0;
    m->initialised = 1;
    return fmi2OK;
}

EXPORT fmi2Status fmi2Terminate(fmi2Component c) { ((Model *)c)->terminated = 1; return fmi2OK; }

EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    Model *m = c;
    defaults(m);
    return fmi2OK;
}

static double real_of(Model *m, fmi2ValueReference r, int *ok) {
    *ok = 1;
    switch (r) {
    case VR_SPEED0: return m->speed0;
    case VR_GAP: return m->gap;
    case VR_MAP_LENGTH: return m->map_length;
    case VR_DISTANCE: return m->gap - m->x;
    case VR_SPEED: return m->v;
    case VR_FRICTION: return m->friction;
    default: *ok = 0; return 0;
    }
}

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Model *m = c;
    size_t i;
    int ok;
    for (i = 0; i < n; i++) {
        v[i] = real_of(m, vr[i], &ok);
        if (!ok) {
            say(m, fmi2Error, "logStatusError", "fmi2GetReal: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] == VR_ROAD) v[i] = m->road;
        else if (vr[i] == VR_STEPS) v[i] = m->steps;
        else {
            say(m, fmi2Error, "logStatusError", "fmi2GetInteger: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_COLLISION) {
            say(m, fmi2Error, "logStatusError", "fmi2GetBoolean: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
        v[i] = m->collision;
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_DRIVER) {
            say(m, fmi2Error, "logStatusError", "fmi2GetString: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
        v[i] = m->driver;
    }
    return fmi2OK;
}

static fmi2Status not_now(Model *m, const char *call, fmi2ValueReference r) {
    say(m, fmi2Error, "logStatusError", "%s: value reference %u cannot be set now", call, r);
    return fmi2Error;
}

EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (m->initialised) return not_now(m, "fmi2SetReal", vr[i]);
        if (vr[i] == VR_SPEED0) m->speed0 = v[i];
        else if (vr[i] == VR_GAP) m->gap = v[i];
        else if (vr[i] == VR_MAP_LENGTH) m->map_length = v[i];
        else return not_now(m, "fmi2SetReal", vr[i]);
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (m->initialised || vr[i] != VR_ROAD) return not_now(m, "fmi2SetInteger", vr[i]);
        m->road = v[i];
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)v;
    return n ? not_now(c, "fmi2SetBoolean", vr[0]) : fmi2OK;
}

EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    Model *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (m->initialised || vr[i] != VR_DRIVER) return not_now(m, "fmi2SetString", vr[i]);
        snprintf(m->driver, sizeof m->driver, "%s", v[i] ? v[i] : "");
    }
    return fmi2OK;
}

/* One explicit Euler step of dt from time t. */
static void euler(Model *m, double t, double dt) {
    double a = (t >= m->reaction) ? m->friction * 9.81 : 0.0;
    if (m->v > 0) {
        m->x += m->v * dt;
        m->v = m->v - a * dt > 0 ? m->v - a * dt : 0.0;
        if (m->gap - m->x <= 0) m->collision = 1; /* reached the obstacle while moving */
    }
    m->steps++;
}

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Model *m = c;
    int k, n = 1;
    (void)noSetPrior;
    if (!m->initialised || m->terminated) {
        say(m, fmi2Error, "logStatusError", "fmi2DoStep: not initialised, or terminated");
        return fmi2Error;
    }
    if (!(h > 0)) {
        say(m, fmi2Error, "logStatusError", "fmi2DoStep: step size %g is not positive", h);
        return fmi2Error;
    }
    if (m->map_length > 0 && m->x >= m->map_length) {
        m->terminated = 1;
        say(m, fmi2Discard, "logStatusDiscard",
            "the car left the map (%.1f m driven, map length %.1f m) at t = %g s: simulation ends",
            m->x, m->map_length, t);
        return fmi2Discard;
    }
    if (m->tolerance_defined && h > m->tolerance) n = (int)ceil(h / m->tolerance);
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
