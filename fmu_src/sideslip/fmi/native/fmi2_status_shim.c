/*
 * fmi2_status_shim.c - the linux64 binary of every sideslip-fmu FMU.
 *
 * It forwards every FMI 2.0 function to pythonfmu's export library (shipped next to it as
 * "pythonfmu_export.so") and fixes two things that library cannot express:
 *
 *  1. Status.  pythonfmu maps every Python exception to fmi2Fatal (and frees the Python
 *     instance), so our Python code never raises; it logs with status fmi2Error or
 *     fmi2Warning instead.  The shim returns the worst status logged during a call, so a
 *     bad parameter gives fmi2Error from fmi2ExitInitializationMode, as FMI 2.0 intends.
 *  2. Logging.  pythonfmu drops every message, errors included, unless loggingOn is set.
 *     The shim always enables logging in pythonfmu and filters itself: warnings and errors
 *     always reach the host; lower levels only when the host asked for them.
 *
 *  3. Speed.  Each pythonfmu get/set builds Python lists and calls into Python (several
 *     microseconds).  Our Python base class keeps its port values (inputs and outputs,
 *     Booleans as 0.0/1.0) in a C double array and publishes it in the String variable
 *     of value reference 0 as "sideslip-ports-v1:<hex address>:<first vr>:<n_in>:<n_ports>:
 *     <kinds>" (kinds: one 'R' or 'B' per port).  When every value reference of a
 *     fmi2Get/SetReal/Boolean call is a port of the right kind (and an input for a set),
 *     the shim serves it from that array; anything else goes through pythonfmu.  The Python
 *     side validates inputs at the start of each doStep, so nothing is lost by writing them
 *     raw.  The layout is read after fmi2Instantiate and fmi2Reset (which re-creates the
 *     Python object); FMU state restore writes into the same array.
 *
 * Messages are forwarded unchanged (pythonfmu passes them as the format argument; the
 * Python side never emits '%').
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <libgen.h>
#include <limits.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define INNER_NAME "pythonfmu_export.so"
#define PORT_MAGIC "sideslip-ports-v1:"

typedef struct {
    fmi2Component inner;
    fmi2CallbackFunctions own;   /* given to pythonfmu: logger -> shim_logger, env -> this */
    fmi2CallbackFunctions host;  /* the host's callbacks */
    int logging_on;
    size_t n_categories;
    char **categories;
    fmi2Status worst;            /* worst status logged during the current call */
    double *ports;               /* shared port array of the Python instance, or NULL */
    fmi2ValueReference first;    /* value reference of port 0 */
    unsigned n_in, n_ports;
    char *kinds;                 /* 'R' / 'B' per port */
} Shim;

static void *g_lib = NULL;

#define INNER(name) static name##TYPE *p_##name = NULL;
INNER(fmi2Instantiate) INNER(fmi2FreeInstance) INNER(fmi2SetupExperiment)
INNER(fmi2EnterInitializationMode) INNER(fmi2ExitInitializationMode) INNER(fmi2Terminate)
INNER(fmi2Reset) INNER(fmi2GetReal) INNER(fmi2GetInteger) INNER(fmi2GetBoolean) INNER(fmi2GetString)
INNER(fmi2SetReal) INNER(fmi2SetInteger) INNER(fmi2SetBoolean) INNER(fmi2SetString)
INNER(fmi2GetFMUstate) INNER(fmi2SetFMUstate) INNER(fmi2FreeFMUstate) INNER(fmi2SerializedFMUstateSize)
INNER(fmi2SerializeFMUstate) INNER(fmi2DeSerializeFMUstate) INNER(fmi2GetDirectionalDerivative)
INNER(fmi2SetRealInputDerivatives) INNER(fmi2GetRealOutputDerivatives) INNER(fmi2DoStep)
INNER(fmi2CancelStep) INNER(fmi2GetStatus) INNER(fmi2GetRealStatus) INNER(fmi2GetIntegerStatus)
INNER(fmi2GetBooleanStatus) INNER(fmi2GetStringStatus)

#define LOAD(name) p_##name = (name##TYPE *)dlsym(g_lib, #name); if (!p_##name) return #name;

/* Load pythonfmu's library from the directory of this shared object; NULL on success,
 * else a description of what failed. */
static const char *load_inner(char *err, size_t n) {
    if (g_lib) return NULL;
    Dl_info info;
    if (!dladdr((void *)&load_inner, &info) || !info.dli_fname) return "dladdr failed";
    char self[PATH_MAX];
    strncpy(self, info.dli_fname, sizeof self - 1);
    self[sizeof self - 1] = '\0';
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/%s", dirname(self), INNER_NAME);
    g_lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!g_lib) {
        snprintf(err, n, "cannot load %s: %s", path, dlerror());
        return err;
    }
    LOAD(fmi2Instantiate) LOAD(fmi2FreeInstance) LOAD(fmi2SetupExperiment)
    LOAD(fmi2EnterInitializationMode) LOAD(fmi2ExitInitializationMode) LOAD(fmi2Terminate)
    LOAD(fmi2Reset) LOAD(fmi2GetReal) LOAD(fmi2GetInteger) LOAD(fmi2GetBoolean) LOAD(fmi2GetString)
    LOAD(fmi2SetReal) LOAD(fmi2SetInteger) LOAD(fmi2SetBoolean) LOAD(fmi2SetString)
    LOAD(fmi2GetFMUstate) LOAD(fmi2SetFMUstate) LOAD(fmi2FreeFMUstate) LOAD(fmi2SerializedFMUstateSize)
    LOAD(fmi2SerializeFMUstate) LOAD(fmi2DeSerializeFMUstate) LOAD(fmi2GetDirectionalDerivative)
    LOAD(fmi2SetRealInputDerivatives) LOAD(fmi2GetRealOutputDerivatives) LOAD(fmi2DoStep)
    LOAD(fmi2CancelStep) LOAD(fmi2GetStatus) LOAD(fmi2GetRealStatus) LOAD(fmi2GetIntegerStatus)
    LOAD(fmi2GetBooleanStatus) LOAD(fmi2GetStringStatus)
    return NULL;
}

static int category_enabled(const Shim *s, fmi2String category) {
    if (!s->logging_on) return 0;
    if (s->n_categories == 0) return 1;
    if (!category) return 0;
    for (size_t i = 0; i < s->n_categories; i++)
        if (strcmp(s->categories[i], category) == 0) return 1;
    return 0;
}

static void shim_logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    Shim *s = (Shim *)env;
    if (status > s->worst) s->worst = status;
    if (s->host.logger && (status >= fmi2Warning || category_enabled(s, category)))
        s->host.logger(s->host.componentEnvironment, instance, status, category, message);
}

static fmi2Status worst(Shim *s, fmi2Status st) { return st > s->worst ? st : s->worst; }

/* Read the port layout published by the Python instance; disables the fast path if absent. */
static void query_layout(Shim *s) {
    free(s->kinds);
    s->kinds = NULL;
    s->ports = NULL;
    fmi2ValueReference vr0 = 0;
    fmi2String text = NULL;
    fmi2Status saved = s->worst;
    if (p_fmi2GetString(s->inner, &vr0, 1, &text) > fmi2Warning || !text) goto done;
    size_t magic = strlen(PORT_MAGIC);
    if (strncmp(text, PORT_MAGIC, magic) != 0) goto done;
    unsigned long long addr = 0;
    unsigned first = 0, n_in = 0, n_ports = 0;
    int used = 0;
    if (sscanf(text + magic, "%llx:%u:%u:%u:%n", &addr, &first, &n_in, &n_ports, &used) != 4) goto done;
    const char *kinds = text + magic + used;
    if (!addr || n_in > n_ports || strlen(kinds) != n_ports) goto done;
    s->kinds = strdup(kinds);
    if (!s->kinds) goto done;
    s->ports = (double *)(uintptr_t)addr;
    s->first = first;
    s->n_in = n_in;
    s->n_ports = n_ports;
done:
    s->worst = saved;
}

/* Index of port vr if it is a port of kind k (inputs only when input_only), else -1. */
static long port_index(const Shim *s, fmi2ValueReference vr, char k, int input_only) {
    if (vr < s->first) return -1;
    unsigned long p = vr - s->first;
    if (p >= (input_only ? s->n_in : s->n_ports) || s->kinds[p] != k) return -1;
    return (long)p;
}

static int all_ports(const Shim *s, const fmi2ValueReference vr[], size_t nvr, char k, int input_only) {
    if (!s->ports) return 0;
    for (size_t i = 0; i < nvr; i++)
        if (port_index(s, vr[i], k, input_only) < 0) return 0;
    return 1;
}

#define CALL(expr) Shim *s = (Shim *)c; s->worst = fmi2OK; fmi2Status st = (expr); return worst(s, st);

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                                          fmi2Boolean loggingOn) {
    char err[PATH_MAX + 256];
    const char *why = load_inner(err, sizeof err);
    if (why) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Fatal, "logStatusFatal", why);
        return NULL;
    }
    Shim *s = (Shim *)calloc(1, sizeof(Shim));
    if (!s) return NULL;
    s->host = *functions;
    s->own = *functions;
    s->own.logger = shim_logger;
    s->own.componentEnvironment = s;
    s->logging_on = loggingOn ? 1 : 0;
    s->inner = p_fmi2Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation, &s->own, visible,
                                 fmi2True);
    if (!s->inner) {
        free(s);
        return NULL;
    }
    query_layout(s);
    return s;
}

static void free_categories(Shim *s) {
    for (size_t i = 0; i < s->n_categories; i++) free(s->categories[i]);
    free(s->categories);
    s->categories = NULL;
    s->n_categories = 0;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    Shim *s = (Shim *)c;
    p_fmi2FreeInstance(s->inner);
    free_categories(s);
    free(s->kinds);
    free(s);
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    Shim *s = (Shim *)c;
    free_categories(s);
    s->logging_on = loggingOn ? 1 : 0;
    if (nCategories > 0 && categories) {
        s->categories = (char **)calloc(nCategories, sizeof(char *));
        if (!s->categories) return fmi2Error;
        for (size_t i = 0; i < nCategories; i++) s->categories[i] = strdup(categories[i] ? categories[i] : "");
        s->n_categories = nCategories;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    CALL(p_fmi2SetupExperiment(s->inner, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime))
}
FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) { CALL(p_fmi2EnterInitializationMode(s->inner)) }
FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) { CALL(p_fmi2ExitInitializationMode(s->inner)) }
FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) { CALL(p_fmi2Terminate(s->inner)) }
FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    Shim *s = (Shim *)c;
    s->worst = fmi2OK;
    s->ports = NULL;                 /* the Python instance and its port array are re-created */
    fmi2Status st = p_fmi2Reset(s->inner);
    if (st <= fmi2Warning) query_layout(s);
    return worst(s, st);
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Shim *s = (Shim *)c;
    if (all_ports(s, vr, nvr, 'R', 0)) {
        for (size_t i = 0; i < nvr; i++) value[i] = s->ports[vr[i] - s->first];
        return fmi2OK;
    }
    s->worst = fmi2OK;
    return worst(s, p_fmi2GetReal(s->inner, vr, nvr, value));
}
FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[]) {
    CALL(p_fmi2GetInteger(s->inner, vr, nvr, value))
}
FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[]) {
    Shim *s = (Shim *)c;
    if (all_ports(s, vr, nvr, 'B', 0)) {
        for (size_t i = 0; i < nvr; i++) value[i] = s->ports[vr[i] - s->first] != 0.0 ? fmi2True : fmi2False;
        return fmi2OK;
    }
    s->worst = fmi2OK;
    return worst(s, p_fmi2GetBoolean(s->inner, vr, nvr, value));
}
FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[]) {
    CALL(p_fmi2GetString(s->inner, vr, nvr, value))
}
FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[]) {
    Shim *s = (Shim *)c;
    if (all_ports(s, vr, nvr, 'R', 1)) {
        for (size_t i = 0; i < nvr; i++) s->ports[vr[i] - s->first] = value[i];
        return fmi2OK;
    }
    s->worst = fmi2OK;
    return worst(s, p_fmi2SetReal(s->inner, vr, nvr, value));
}
FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[]) {
    CALL(p_fmi2SetInteger(s->inner, vr, nvr, value))
}
FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[]) {
    Shim *s = (Shim *)c;
    if (all_ports(s, vr, nvr, 'B', 1)) {
        for (size_t i = 0; i < nvr; i++) s->ports[vr[i] - s->first] = value[i] ? 1.0 : 0.0;
        return fmi2OK;
    }
    s->worst = fmi2OK;
    return worst(s, p_fmi2SetBoolean(s->inner, vr, nvr, value));
}
FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[]) {
    CALL(p_fmi2SetString(s->inner, vr, nvr, value))
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CALL(p_fmi2GetFMUstate(s->inner, FMUstate))
}
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CALL(p_fmi2SetFMUstate(s->inner, FMUstate))
}
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CALL(p_fmi2FreeFMUstate(s->inner, FMUstate))
}
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CALL(p_fmi2SerializedFMUstateSize(s->inner, FMUstate, size))
}
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                             size_t size) {
    CALL(p_fmi2SerializeFMUstate(s->inner, FMUstate, serializedState, size))
}
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                               fmi2FMUstate *FMUstate) {
    CALL(p_fmi2DeSerializeFMUstate(s->inner, serializedState, size, FMUstate))
}
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    CALL(p_fmi2GetDirectionalDerivative(s->inner, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown, dvUnknown))
}
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    CALL(p_fmi2SetRealInputDerivatives(s->inner, vr, nvr, order, value))
}
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    CALL(p_fmi2GetRealOutputDerivatives(s->inner, vr, nvr, order, value))
}
FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    CALL(p_fmi2DoStep(s->inner, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint))
}
FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) { CALL(p_fmi2CancelStep(s->inner)) }
FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status *value) {
    CALL(p_fmi2GetStatus(s->inner, kind, value))
}
FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real *value) {
    CALL(p_fmi2GetRealStatus(s->inner, kind, value))
}
FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Integer *value) {
    CALL(p_fmi2GetIntegerStatus(s->inner, kind, value))
}
FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Boolean *value) {
    CALL(p_fmi2GetBooleanStatus(s->inner, kind, value))
}
FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind, fmi2String *value) {
    CALL(p_fmi2GetStringStatus(s->inner, kind, value))
}
