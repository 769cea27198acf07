/*
 * win_probe.c - a minimal Windows FMI 2.0 host for the win64 binaries (run under Wine by the tests).
 *
 * Usage: win_probe.exe <binary.dll> <guid> <resource URI>
 * Loads the DLL, calls fmi2GetVersion and fmi2Instantiate (Co-Simulation, logging on) and prints every
 * logged message as "LOG <status> <category>: <message>", then "INSTANCE NULL" or "INSTANCE OK" (and
 * frees it).  Exit code 0 unless the DLL or its functions cannot be found.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <windows.h>

#include "fmi2FunctionTypes.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    (void)name;
    printf("LOG %d %s: %s\n", (int)status, category ? category : "", message ? message : "");
    fflush(stdout);
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: %s <binary.dll> <guid> <resource URI>\n", argv[0]);
        return 2;
    }
    HMODULE dll = LoadLibraryExA(argv[1], NULL, LOAD_WITH_ALTERED_SEARCH_PATH);
    if (!dll) {
        fprintf(stderr, "cannot load %s (error %lu)\n", argv[1], (unsigned long)GetLastError());
        return 3;
    }
    fmi2GetVersionTYPE *version = (fmi2GetVersionTYPE *)(void *)GetProcAddress(dll, "fmi2GetVersion");
    fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)(void *)GetProcAddress(dll, "fmi2Instantiate");
    fmi2FreeInstanceTYPE *free_instance = (fmi2FreeInstanceTYPE *)(void *)GetProcAddress(dll, "fmi2FreeInstance");
    if (!version || !instantiate || !free_instance) {
        fprintf(stderr, "missing FMI functions\n");
        return 4;
    }
    printf("VERSION %s\n", version());
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("probe", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2True);
    printf("INSTANCE %s\n", c ? "OK" : "NULL");
    if (c) free_instance(c);
    return 0;
}
