/*
 * fmi2_importer.c - a minimal FMI 2.0 co-simulation importer in plain C (test tool).
 *
 * It stands for a non-Python host (OMSimulator, Simulink, a customer's own C code): it is
 * not linked with libpython and loads the FMU's linux64 binary with dlopen, so the FMU must
 * bring its own interpreter.
 *
 *   fmi2_importer UNZIPDIR MODEL_ID GUID STEP INPUTS.csv OUTPUTS.csv [VR ...]
 *
 * INPUTS.csv: header "time,<K><vr>,..." with K = R (Real) or B (Boolean), one row per
 * communication step (time = communication point).  For each row the importer sets the
 * inputs, calls fmi2DoStep(time, STEP) and appends "time+STEP,<output vr>..." to
 * OUTPUTS.csv for the Real value references VR given on the command line (%.17g).
 * Exit status: 0 on success, 2 on usage or file errors, 3 on an FMI status worse than
 * fmi2Warning.  The FMU's log goes to stderr; IMPORTER_LOGGING=1 instantiates with
 * loggingOn (all categories).  IMPORTER_SECOND="UNZIPDIR2 MODEL_ID2 GUID2" also loads a
 * second FMU into the same process and steps it alongside at its start values (a host with
 * several FMUs, as OMSimulator or Simulink would have).
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    va_list ap;
    va_start(ap, message);
    fprintf(stderr, "[%d] %s %s: ", (int)status, instance ? instance : "", category ? category : "");
    vfprintf(stderr, message, ap);
    fputc('\n', stderr);
    va_end(ap);
}

#define LOAD(name)                                                                   \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);                              \
    if (!name) {                                                                     \
        fprintf(stderr, "missing symbol %s\n", #name);                               \
        return 2;                                                                    \
    }

#define CHECK(call)                                                                  \
    do {                                                                             \
        fmi2Status st_ = (call);                                                     \
        if (st_ > fmi2Warning) {                                                     \
            fprintf(stderr, "%s returned status %d\n", #call, (int)st_);             \
            return 3;                                                                \
        }                                                                            \
    } while (0)

int main(int argc, char **argv) {
    if (argc < 7) {
        fprintf(stderr, "usage: %s UNZIPDIR MODEL_ID GUID STEP INPUTS.csv OUTPUTS.csv [VR ...]\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1], *model = argv[2], *guid = argv[3];
    double h = atof(argv[4]);
    size_t n_out = (size_t)(argc - 7);
    fmi2ValueReference *out_vr = calloc(n_out + 1, sizeof *out_vr);
    fmi2Real *out = calloc(n_out + 1, sizeof *out);
    for (size_t i = 0; i < n_out; i++) out_vr[i] = (fmi2ValueReference)strtoul(argv[7 + i], NULL, 10);

    char path[4096], uri[4200];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, model);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen %s: %s\n", path, dlerror());
        return 2;
    }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2SetReal) LOAD(fmi2SetBoolean) LOAD(fmi2GetReal)
    LOAD(fmi2DoStep) LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)

    FILE *fin = fopen(argv[5], "r"), *fout = fopen(argv[6], "w");
    if (!fin || !fout) {
        fprintf(stderr, "cannot open %s or %s\n", argv[5], argv[6]);
        return 2;
    }
    /* header: time,R12,B40,... */
    static char line[1 << 16];
    if (!fgets(line, sizeof line, fin)) return 2;
    size_t cap = 64, n_in = 0;
    char *kind = malloc(cap);
    fmi2ValueReference *in_vr = malloc(cap * sizeof *in_vr);
    char *save = NULL;
    strtok_r(line, ",\r\n", &save);                              /* "time" */
    for (char *tok = strtok_r(NULL, ",\r\n", &save); tok; tok = strtok_r(NULL, ",\r\n", &save)) {
        if (n_in == cap) {
            cap *= 2;
            kind = realloc(kind, cap);
            in_vr = realloc(in_vr, cap * sizeof *in_vr);
        }
        if (tok[0] != 'R' && tok[0] != 'B') {
            fprintf(stderr, "bad input column %s (expected R<vr> or B<vr>)\n", tok);
            return 2;
        }
        kind[n_in] = tok[0];
        in_vr[n_in++] = (fmi2ValueReference)strtoul(tok + 1, NULL, 10);
    }

    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    snprintf(uri, sizeof uri, "file://%s/resources", dir);
    const char *logging = getenv("IMPORTER_LOGGING");
    fmi2Boolean logging_on = logging && strcmp(logging, "1") == 0;
    fmi2Component c = fmi2Instantiate("importer", fmi2CoSimulation, guid, uri, &cb, fmi2False, logging_on);
    if (!c) {
        fprintf(stderr, "fmi2Instantiate failed\n");
        return 3;
    }
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(fmi2EnterInitializationMode(c));
    CHECK(fmi2ExitInitializationMode(c));

    /* optional second FMU: its own binary, same process */
    fmi2DoStepTYPE *do_step2 = NULL;
    fmi2FreeInstanceTYPE *free2 = NULL;
    fmi2Component c2 = NULL;
    const char *second = getenv("IMPORTER_SECOND");
    if (second && *second) {
        char dir2[4096], model2[256], guid2[256], path2[4400], uri2[4200];
        if (sscanf(second, "%4095s %255s %255s", dir2, model2, guid2) != 3) {
            fprintf(stderr, "IMPORTER_SECOND: expected 'UNZIPDIR MODEL_ID GUID'\n");
            return 2;
        }
        snprintf(path2, sizeof path2, "%s/binaries/linux64/%s.so", dir2, model2);
        void *lib2 = dlopen(path2, RTLD_NOW | RTLD_LOCAL);
        if (!lib2) {
            fprintf(stderr, "dlopen %s: %s\n", path2, dlerror());
            return 2;
        }
        fmi2InstantiateTYPE *inst2 = (fmi2InstantiateTYPE *)dlsym(lib2, "fmi2Instantiate");
        fmi2SetupExperimentTYPE *setup2 = (fmi2SetupExperimentTYPE *)dlsym(lib2, "fmi2SetupExperiment");
        fmi2EnterInitializationModeTYPE *enter2 = (fmi2EnterInitializationModeTYPE *)dlsym(lib2, "fmi2EnterInitializationMode");
        fmi2ExitInitializationModeTYPE *exit2 = (fmi2ExitInitializationModeTYPE *)dlsym(lib2, "fmi2ExitInitializationMode");
        do_step2 = (fmi2DoStepTYPE *)dlsym(lib2, "fmi2DoStep");
        free2 = (fmi2FreeInstanceTYPE *)dlsym(lib2, "fmi2FreeInstance");
        snprintf(uri2, sizeof uri2, "file://%s/resources", dir2);
        c2 = inst2 ? inst2("second", fmi2CoSimulation, guid2, uri2, &cb, fmi2False, fmi2False) : NULL;
        if (!c2 || !setup2 || !enter2 || !exit2 || !do_step2 || !free2) {
            fprintf(stderr, "second FMU: instantiation failed\n");
            return 3;
        }
        CHECK(setup2(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(enter2(c2));
        CHECK(exit2(c2));
    }

    double *values = malloc((n_in + 1) * sizeof *values);
    size_t steps = 0;
    while (fgets(line, sizeof line, fin)) {
        save = NULL;
        char *tok = strtok_r(line, ",\r\n", &save);
        if (!tok) continue;
        double t = strtod(tok, NULL);
        for (size_t i = 0; i < n_in; i++) {
            tok = strtok_r(NULL, ",\r\n", &save);
            if (!tok) {
                fprintf(stderr, "row %zu: %zu values expected\n", steps + 1, n_in);
                return 2;
            }
            values[i] = strtod(tok, NULL);
        }
        for (size_t i = 0; i < n_in; i++) {
            if (kind[i] == 'R') {
                CHECK(fmi2SetReal(c, &in_vr[i], 1, &values[i]));
            } else {
                fmi2Boolean b = values[i] != 0.0;
                CHECK(fmi2SetBoolean(c, &in_vr[i], 1, &b));
            }
        }
        CHECK(fmi2DoStep(c, t, h, fmi2True));
        if (c2) CHECK(do_step2(c2, t, h, fmi2True));
        if (n_out) CHECK(fmi2GetReal(c, out_vr, n_out, out));
        fprintf(fout, "%.17g", t + h);
        for (size_t i = 0; i < n_out; i++) fprintf(fout, ",%.17g", out[i]);
        fputc('\n', fout);
        steps++;
    }
    CHECK(fmi2Terminate(c));
    fmi2FreeInstance(c);
    if (c2) free2(c2);
    fclose(fout);
    fclose(fin);
    fprintf(stderr, "%zu steps\n", steps);
    return 0;
}
