/* The test FMUs' control law (FMI 2.0: pi_controller.c, FMI 3.0: pi_controller3.c).
 *
 *   w      = GenSpeed [rpm] * pi / 30                     generator speed [rad/s]
 *   e      = w - SpeedRef [rad/s]
 *   I      = clamp(I + Ki e h, PitchMin, PitchMax)         integral term [rad]
 *   pitch  = clamp(Kp e + I, PitchMin, PitchMax)           [rad]
 *   torque = min(Kopt w^2, TorqueMax)                      [N m]
 *   SpeedFilt = w, Regime = 4 if pitch > PitchMin + 0.01 else 2
 * Outputs: PitchCmd [deg], TorqueCmd [kN.m], SpeedFilt [rad/s], PitchInt [rad], Regime.
 * The Python twin of this law is PiLaw in tests/test_fmu.py.
 */
#ifndef PI_LAW_H
#define PI_LAW_H

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

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

static const double PI_LAW_START[N_REAL] = {
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
    -1.0,        /* FailTime s: >= 0 makes doStep fail from that time on */
    0.0,         /* Wind m/s (an input the law ignores) */
};

typedef struct {
    double r[N_REAL];
    int regime;
    double integ;
} PiLaw;

static void pi_reset(PiLaw *m) {
    memcpy(m->r, PI_LAW_START, sizeof PI_LAW_START);
    m->regime = 2;
    m->integ = 0.0;
}

static double pi_clamp(double x, double lo, double hi) {
    return x < lo ? lo : (x > hi ? hi : x);
}

/* One communication step from t over h; 0, or -1 when FailTime asks for a failure. */
static int pi_step(PiLaw *m, double t, double h) {
    double *r = m->r;
    if (r[VR_FAIL_TIME] >= 0.0 && t >= r[VR_FAIL_TIME]) return -1;
    double w = r[VR_GEN_SPEED] * M_PI / 30.0;
    double e = w - r[VR_SPEED_REF];
    m->integ = pi_clamp(m->integ + r[VR_KI] * e * h, r[VR_PITCH_MIN], r[VR_PITCH_MAX]);
    double pitch = pi_clamp(r[VR_KP] * e + m->integ, r[VR_PITCH_MIN], r[VR_PITCH_MAX]);
    double torque = r[VR_KOPT] * w * w;
    if (torque > r[VR_TORQUE_MAX]) torque = r[VR_TORQUE_MAX];
    r[VR_PITCH_CMD] = pitch * 180.0 / M_PI;
    r[VR_TORQUE_CMD] = torque / 1000.0;
    r[VR_SPEED_FILT] = w;
    r[VR_PITCH_INT] = m->integ;
    m->regime = pitch > r[VR_PITCH_MIN] + 0.01 ? 4 : 2;
    return 0;
}

#endif
