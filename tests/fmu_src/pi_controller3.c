/* The test FMU's law (pi_law.h) as an FMI 3.0 co-simulation FMU: the functions the bench
 * calls. The rest of the FMI 3.0 API, which fmpy loads but the bench never calls (clocks,
 * other integer widths, binaries, FMU states, model exchange), is in fmi3_stubs.c.
 * FailTime >= 0: fmi3DoStep returns fmi3Error once t >= FailTime.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "pi_law.h"

typedef struct {
    PiLaw law;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} Model;

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n,
                               const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token,
                                         fmi3String resources, fmi3Boolean visible,
                                         fmi3Boolean logging, fmi3Boolean eventMode,
                                         fmi3Boolean earlyReturn,
                                         const fmi3ValueReference required[], size_t nRequired,
                                         fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback log,
                                         fmi3IntermediateUpdateCallback update) {
    (void)name; (void)token; (void)resources; (void)visible; (void)logging; (void)eventMode;
    (void)earlyReturn; (void)required; (void)nRequired; (void)update;
    Model *m = calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->env = env;
    m->log = log;
    pi_reset(&m->law);
    return m;
}

void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol,
                                       fmi3Float64 start, fmi3Boolean stopDef,
                                       fmi3Float64 stop) {
    (void)c; (void)tolDef; (void)tol; (void)start; (void)stopDef; (void)stop;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) {
    pi_reset(&((Model *)c)->law);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                          fmi3Float64 v[], size_t nv) {
    Model *m = c;
    if (nv != n) return fmi3Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_REAL) return fmi3Error;
        v[k] = m->law.r[vr[k]];
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                          const fmi3Float64 v[], size_t nv) {
    Model *m = c;
    if (nv != n) return fmi3Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_REAL) return fmi3Error;
        m->law.r[vr[k]] = v[k];
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                        fmi3Int32 v[], size_t nv) {
    Model *m = c;
    if (nv != n) return fmi3Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 100) return fmi3Error; /* Regime */
        v[k] = m->law.regime;
    }
    return fmi3OK;
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                        const fmi3Int32 v[], size_t nv) {
    (void)c; (void)vr; (void)v; (void)nv;
    return n == 0 ? fmi3OK : fmi3Error;
}
fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                          const fmi3Boolean v[], size_t nv) {
    (void)c; (void)vr; (void)v; (void)nv;
    return n == 0 ? fmi3OK : fmi3Error;
}
fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                         const fmi3String v[], size_t nv) {
    (void)c; (void)vr; (void)v; (void)nv;
    return n == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
                      fmi3Boolean *eventNeeded, fmi3Boolean *terminate,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastTime) {
    Model *m = c;
    (void)noSetPrior;
    *eventNeeded = fmi3False;
    *terminate = fmi3False;
    *earlyReturn = fmi3False;
    *lastTime = t + h;
    if (pi_step(&m->law, t, h) != 0) {
        if (m->log) m->log(m->env, fmi3Error, "logStatusError", "failing as asked by FailTime");
        *lastTime = t;
        return fmi3Error;
    }
    return fmi3OK;
}
