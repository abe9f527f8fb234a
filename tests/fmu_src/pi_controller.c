/* A small FMI 2.0 co-simulation FMU for the bench's tests: a generator-speed PI on pitch and
 * a K omega^2 torque law, with units the bench converts (rpm in, deg and kN.m out).
 *
 * Every doStep(t, h):
 *   w      = GenSpeed [rpm] * pi / 30                     generator speed [rad/s]
 *   e      = w - SpeedRef [rad/s]
 *   I      = clamp(I + Ki e h, PitchMin, PitchMax)         integral term [rad]
 *   pitch  = clamp(Kp e + I, PitchMin, PitchMax)           [rad]
 *   torque = min(Kopt w^2, TorqueMax)                      [N m]
 *   SpeedFilt = w, Regime = 4 if pitch > PitchMin + 0.01 else 2
 * Outputs: PitchCmd [deg], TorqueCmd [kN.m], SpeedFilt [rad/s], PitchInt [rad], Regime.
 * FailTime >= 0: doStep returns fmi2Error once t >= FailTime (a controller that fails in a
 * run). The Python twin of this law is in tests/test_fmu.py.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

enum {
    VR_GEN_SPEED = 0,
    VR_PITCH_CMD = 1,
    VR_TORQUE_CMD = 2,
    VR_SPEED_FILT = 3,
    VR_PITCH_INT = 4,
    VR_KP = 5,
    VR_KI = 6,
    VR_SPEED_REF = 7,
    VR_KOPT = 8,
    VR_TORQUE_MAX = 9,
    VR_PITCH_MIN = 10,
    VR_PITCH_MAX = 11,
    VR_FAIL_TIME = 12,
    VR_WIND = 13,
    N_REAL = 14
};
enum { VR_REGIME = 0, N_INT = 1 };

typedef struct {
    double r[N_REAL];
    int i[N_INT];
    double integ;
    fmi2CallbackFunctions cb;
    char *name;
} Model;

static const double START[N_REAL] = {
    0.0,         /* GenSpeed rpm */
    0.0,         /* PitchCmd deg */
    0.0,         /* TorqueCmd kN.m */
    0.0,         /* SpeedFilt rad/s */
    0.0,         /* PitchInt rad */
    0.01882681,  /* Kp s */
    0.008068634, /* Ki */
    122.9096,    /* SpeedRef rad/s */
    2.332287,    /* Kopt N m/(rad/s)^2 */
    43093.55,    /* TorqueMax N m */
    0.0,         /* PitchMin rad */
    1.5707963,   /* PitchMax rad */
    -1.0,        /* FailTime s */
    0.0,         /* Wind m/s (an input the law ignores) */
};

static void reset_model(Model *m) {
    memcpy(m->r, START, sizeof START);
    m->i[VR_REGIME] = 2;
    m->integ = 0.0;
}

static double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                              fmi2String resources, const fmi2CallbackFunctions *cb,
                              fmi2Boolean visible, fmi2Boolean logging) {
    (void)guid; (void)resources; (void)visible; (void)logging;
    if (type != fmi2CoSimulation) return NULL;
    Model *m = calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->cb = *cb;
    m->name = strdup(name ? name : "pi");
    reset_model(m);
    return m;
}

void fmi2FreeInstance(fmi2Component c) {
    Model *m = c;
    if (!m) return;
    free(m->name);
    free(m);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol,
                               fmi2Real start, fmi2Boolean stopDef, fmi2Real stop) {
    (void)c; (void)tolDef; (void)tol; (void)start; (void)stopDef; (void)stop;
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { reset_model(c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Model *m = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_REAL) return fmi2Error;
        v[k] = m->r[vr[k]];
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2Integer v[]) {
    Model *m = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_INT) return fmi2Error;
        v[k] = m->i[vr[k]];
    }
    return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2Boolean v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                         fmi2String v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                       const fmi2Real v[]) {
    Model *m = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_REAL) return fmi2Error;
        m->r[vr[k]] = v[k];
    }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2Integer v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2Boolean v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                         const fmi2String v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)c; (void)s; (void)n;
    return fmi2Error;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)c; (void)s; (void)b; (void)n;
    return fmi2Error;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                   fmi2FMUstate *s) {
    (void)c; (void)b; (void)n; (void)s;
    return fmi2Error;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[]) {
    (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return fmi2Error;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer o[], const fmi2Real v[]) {
    (void)c; (void)vr; (void)n; (void)o; (void)v;
    return fmi2Error;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t n, const fmi2Integer o[], fmi2Real v[]) {
    (void)c; (void)vr; (void)n; (void)o; (void)v;
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Model *m = c;
    double *r = m->r;
    (void)noSetPrior;
    if (r[VR_FAIL_TIME] >= 0.0 && t >= r[VR_FAIL_TIME]) {
        if (m->cb.logger)
            m->cb.logger(m->cb.componentEnvironment, m->name, fmi2Error, "logError",
                         "failing as asked by FailTime");
        return fmi2Error;
    }
    double w = r[VR_GEN_SPEED] * M_PI / 30.0;
    double e = w - r[VR_SPEED_REF];
    m->integ = clamp(m->integ + r[VR_KI] * e * h, r[VR_PITCH_MIN], r[VR_PITCH_MAX]);
    double pitch = clamp(r[VR_KP] * e + m->integ, r[VR_PITCH_MIN], r[VR_PITCH_MAX]);
    double torque = r[VR_KOPT] * w * w;
    if (torque > r[VR_TORQUE_MAX]) torque = r[VR_TORQUE_MAX];
    r[VR_PITCH_CMD] = pitch * 180.0 / M_PI;
    r[VR_TORQUE_CMD] = torque / 1000.0;
    r[VR_SPEED_FILT] = w;
    r[VR_PITCH_INT] = m->integ;
    m->i[VR_REGIME] = pitch > r[VR_PITCH_MIN] + 0.01 ? 4 : 2;
    return fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
