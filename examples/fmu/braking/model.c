/*
 * The braking model without an FMI API: included by braking.c (the FMI 2.0 C API) and
 * braking3.c (the FMI 3.0 C API), the way vendors share one model between the two versions.
 *
 * A car at `speed0` approaches a stopped obstacle `gap` metres ahead; the driver reacts after a
 * reaction time (String parameter `driver`: "alert" 0.8 s, "distracted" 1.6 s) and brakes with
 * friction * 9.81 m/s^2, the friction of the `road` (Enumeration dry/wet/ice) read from
 * resources/friction.txt during initialisation. The state is integrated with explicit Euler at
 * the communication step — or, when the importer gives a tolerance, in sub-steps of at most
 * `tolerance` seconds — so the step size and the tolerance are its fidelity. It has no
 * fidelity parameter of its own.
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EXPORT __attribute__((visibility("default")))

/* The statuses have the same numbers in FMI 2.0 and 3.0. */
enum { ST_OK, ST_WARNING, ST_DISCARD, ST_ERROR, ST_FATAL };

enum { VR_SPEED0, VR_GAP, VR_ROAD, VR_DRIVER, VR_MAP_LENGTH, VR_DISTANCE, VR_SPEED,
       VR_COLLISION, VR_STEPS, VR_FRICTION, VR_TIME };

typedef struct Model Model;
/* Hands a formatted message to the importer's logger (FMI 2.0 or 3.0). */
typedef void (*Emit)(Model *m, int status, const char *category, const char *text);

struct Model {
    char *name;
    char *resources; /* a directory path */
    Emit emit;
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
};

static void say(Model *m, int status, const char *category, const char *fmt, ...) {
    char buf[1024];
    va_list ap;
    if (status == ST_OK && !m->logging) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    m->emit(m, status, category, buf);
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

/* The friction of road surface `road` (1 dry, 2 wet, 3 ice) from resources/friction.txt. */
static int read_friction(Model *m) {
    static const char *names[] = {"dry", "wet", "ice"};
    char path[4096], line[256], surface[64];
    double mu;
    size_t n;
    FILE *f;
    if (m->road < 1 || m->road > 3) {
        say(m, ST_ERROR, "logStatusError", "road = %d is not 1 (dry), 2 (wet) or 3 (ice)", m->road);
        return ST_ERROR;
    }
    if (!m->resources) {
        say(m, ST_ERROR, "logStatusError", "no resource location: cannot read friction.txt");
        return ST_ERROR;
    }
    n = strlen(m->resources);
    snprintf(path, sizeof path, "%s%sfriction.txt", m->resources,
             n > 0 && m->resources[n - 1] == '/' ? "" : "/");
    f = fopen(path, "r");
    if (!f) {
        say(m, ST_ERROR, "logStatusError", "cannot open %s: %s", path, strerror(errno));
        return ST_ERROR;
    }
    while (fgets(line, sizeof line, f)) {
        if (sscanf(line, "%63s %lf", surface, &mu) == 2 && strcmp(surface, names[m->road - 1]) == 0) {
            fclose(f);
            m->friction = mu;
            say(m, ST_OK, "logAll", "friction %.2f for the %s road from %s", mu, surface, path);
            return ST_OK;
        }
    }
    fclose(f);
    say(m, ST_ERROR, "logStatusError", "%s has no line for the %s road", path, names[m->road - 1]);
    return ST_ERROR;
}

/* The end of initialisation: the driver's reaction time, the road's friction, the start. */
static int model_initialise(Model *m) {
    if (strcmp(m->driver, "alert") == 0) m->reaction = 0.8;
    else if (strcmp(m->driver, "distracted") == 0) m->reaction = 1.6;
    else {
        say(m, ST_ERROR, "logStatusError", "unknown driver profile '%s' (expected alert or distracted)",
            m->driver);
        return ST_ERROR;
    }
    if (read_friction(m) != ST_OK) return ST_ERROR;
    m->x = 0.0;
    m->v = m->speed0;
    m->initialised = 1;
    return ST_OK;
}

static double real_of(Model *m, unsigned r, int *ok) {
    *ok = 1;
    switch (r) {
    case VR_SPEED0: return m->speed0;
    case VR_GAP: return m->gap;
    case VR_MAP_LENGTH: return m->map_length;
    case VR_DISTANCE: return m->gap - m->x;
    case VR_SPEED: return m->v;
    case VR_FRICTION: return m->friction;
    case VR_TIME: return m->time;
    default: *ok = 0; return 0;
    }
}

static int not_now(Model *m, const char *call, unsigned r) {
    say(m, ST_ERROR, "logStatusError", "%s: value reference %u cannot be set now", call, r);
    return ST_ERROR;
}

static int set_real(Model *m, const char *call, unsigned r, double v) {
    if (m->initialised) return not_now(m, call, r);
    if (r == VR_SPEED0) m->speed0 = v;
    else if (r == VR_GAP) m->gap = v;
    else if (r == VR_MAP_LENGTH) m->map_length = v;
    else return not_now(m, call, r);
    return ST_OK;
}

static int set_road(Model *m, const char *call, unsigned r, long long v) {
    if (m->initialised || r != VR_ROAD) return not_now(m, call, r);
    m->road = (int)v;
    return ST_OK;
}

static int set_driver(Model *m, const char *call, unsigned r, const char *v) {
    if (m->initialised || r != VR_DRIVER) return not_now(m, call, r);
    snprintf(m->driver, sizeof m->driver, "%s", v ? v : "");
    return ST_OK;
}

static int unknown(Model *m, const char *call, unsigned r) {
    say(m, ST_ERROR, "logStatusError", "%s: unknown value reference %u", call, r);
    return ST_ERROR;
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

/* The checks every doStep makes first. */
static int can_step(Model *m, const char *call, double h) {
    if (!m->initialised || m->terminated) {
        say(m, ST_ERROR, "logStatusError", "%s: not initialised, or terminated", call);
        return 0;
    }
    if (!(h > 0)) {
        say(m, ST_ERROR, "logStatusError", "%s: step size %g is not positive", call, h);
        return 0;
    }
    return 1;
}

/* The number of Euler sub-steps of a communication step of h. */
static int substeps(const Model *m, double h) {
    return (m->tolerance_defined && h > m->tolerance) ? (int)ceil(h / m->tolerance) : 1;
}

/* Whether the car has left the map (and the simulation should end), logged once. */
static int left_map(Model *m, double t) {
    if (!(m->map_length > 0 && m->x >= m->map_length)) return 0;
    m->terminated = 1;
    say(m, ST_DISCARD, "logStatusDiscard",
        "the car left the map (%.1f m driven, map length %.1f m) at t = %g s: simulation ends",
        m->x, m->map_length, t);
    return 1;
}
