/*
 * fmi2_status_shim.c - the linux64 and win64 binary of every sideslip-fmu FMU.
 *
 * It forwards every FMI 2.0 function to pythonfmu's export library (shipped next to it as
 * "pythonfmu_export.so" / "pythonfmu_export.dll") and adds what that library cannot do:
 *
 *  0. Python for hosts that have none.  pythonfmu's library expects the host process to
 *     hold libpython (a C host fails with "undefined symbol: _Py_NoneStruct").  Before
 *     loading it, the shim looks for a running interpreter; if there is none it loads
 *     libpython with RTLD_GLOBAL from $SIDESLIP_FMU_LIBPYTHON if set, else the library of
 *     the Python the FMU was built with, else the usual sonames of that Python version;
 *     initialises it (no signal handlers; PYTHONHOME set to the build Python's prefix for
 *     the call when that is the library loaded and the user has not set PYTHONHOME), adds
 *     the site-packages of the build environment ($SIDESLIP_FMU_SITE_PACKAGES, a ':' list,
 *     overrides them) and releases the GIL so that pythonfmu can take it from any thread.
 *     Inside a Python host (fmpy, ...) the interpreter is running and nothing changes.
 *     The build writes the build-time paths into "shim_config.h" (see sideslip/fmi/build.py).
 *     On Windows (cross-compiled with mingw-w64; no build-time Python applies there) the
 *     interpreter is python3X.dll of the FMUs' Python version, found in this order:
 *     %SIDESLIP_FMU_LIBPYTHON% (the DLL's path), the Python the user configured (%PYTHONHOME%,
 *     then the DLL search path, i.e. the Python put on PATH), then the Python launcher's
 *     registry entries (HKCU, then HKLM, Software\Python\PythonCore\3.X\InstallPath).  Its
 *     python3.dll (which pythonfmu's library imports) is loaded from the same folder, and its
 *     folder is the home of the interpreter unless PYTHONHOME is set.  When none is found,
 *     fmi2Instantiate logs what was tried and returns NULL.
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
 *  4. Robustness.  fmi2Instantiate refuses a GUID that is not this FMU's (compiled in by the
 *     builder) and Model Exchange.  FMU states are wrapped in a struct of the shim's (NULL, a
 *     freed or foreign state is refused with fmi2Error, never handed to pythonfmu); serialised
 *     states carry a frame (magic, version, length, FNV-1a checksum) checked before pythonfmu
 *     sees the bytes; fmi2SerializeFMUstate refuses a buffer of the wrong size.  Once pythonfmu
 *     has returned fmi2Fatal (it then frees its Python instance) every later call is refused
 *     instead of reaching freed memory.  After fmi2Terminate the port fast path refuses sets.
 *  6. Instances are reused.  pythonfmu 0.7 leaks about 1 KB at every fmi2Instantiate (it
 *     compiles the wrapper again and keeps a list of the class's MRO), so a host that instantiates
 *     and frees in a loop would grow without bound.  fmi2FreeInstance resets the instance
 *     (pythonfmu re-creates the Python object, which costs nothing lasting) and keeps up to
 *     POOL_MAX of them; fmi2Instantiate takes one of the same resource location from there.  The
 *     host's name and callbacks are the new ones: the shim passes its own instance name to the
 *     host's logger, and the Python side's messages do not name the instance.
 *  7. A freed instance stays freed.  fmi2FreeInstance looks the pointer up among the instances it
 *     handed out (a short list under the pool's lock): freeing one twice, or a pointer that was
 *     never an instance of this FMU, does nothing, and a freed instance kept for reuse refuses every
 *     call until fmi2Instantiate hands it out again.
 *  5. Status.  Warnings are logged but do not change the returned status: hosts such as
 *     OMSimulator and fmusim stop on fmi2Warning, and the FMUs use warnings only for conditions
 *     they handle (a held or clamped input); errors still give fmi2Error.
 *
 * Messages are forwarded unchanged (pythonfmu passes them as the format argument; the
 * Python side never emits '%').
 */
#ifdef _WIN32
#define _WIN32_WINNT 0x0601              /* Windows 7: RegGetValueA, SRW locks */
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#else
#define _GNU_SOURCE
#include <dlfcn.h>
#include <libgen.h>
#include <limits.h>
#include <pthread.h>
#endif
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* Build-time paths (generated by sideslip/fmi/build.py); empty defaults keep the file
 * compilable on its own. */
#if defined(__has_include)
#if __has_include("shim_config.h")
#include "shim_config.h"
#endif
#endif
#ifndef SIDESLIP_BUILD_LIBPYTHON
#define SIDESLIP_BUILD_LIBPYTHON ""      /* libpython of the build Python */
#endif
#ifndef SIDESLIP_BUILD_HOME
#define SIDESLIP_BUILD_HOME ""           /* its sys.base_prefix */
#endif
#ifndef SIDESLIP_BUILD_SITE
#define SIDESLIP_BUILD_SITE ""           /* site-packages of the build environment, ':'-separated */
#endif
#ifndef SIDESLIP_PY_SONAMES
#define SIDESLIP_PY_SONAMES "libpython3.so" /* fallback sonames, ':'-separated */
#endif
#ifndef SIDESLIP_FMU_GUID
#define SIDESLIP_FMU_GUID ""             /* the FMU's GUID (empty: not checked) */
#endif
#ifndef SIDESLIP_PY_VERSION
#define SIDESLIP_PY_VERSION "3.11"       /* Windows: the Python version the FMUs need */
#endif
#ifndef SIDESLIP_PY_DLL
#define SIDESLIP_PY_DLL "python311.dll"  /* Windows: its DLL */
#endif

#define STATE_MAGIC 0x53535354u          /* "SSST": a live FMU state of this shim */
#define FRAME_MAGIC "SSFMU-STATE-FRAME"  /* serialised states */
#define FRAME_VERSION 1u
#define FRAME_HEAD (sizeof(FRAME_MAGIC) - 1 + 4 + 8 + 8)

#define PORT_MAGIC "sideslip-ports-v2:"

/* ------------------------------------------------------------------ platform */
#ifdef _WIN32
#define INNER_NAME "pythonfmu_export.dll"
typedef HMODULE lib_handle;
typedef SRWLOCK shim_lock;
#define SHIM_LOCK_INIT SRWLOCK_INIT
static void lock_take(shim_lock *l) { AcquireSRWLockExclusive(l); }
static void lock_give(shim_lock *l) { ReleaseSRWLockExclusive(l); }
static void *lib_symbol(lib_handle h, const char *name) { return h ? (void *)GetProcAddress(h, name) : NULL; }
static lib_handle lib_load(const char *path) {
    /* a full path: its own folder first for its dependencies */
    int full = strchr(path, '\\') || strchr(path, '/');
    return LoadLibraryExA(path, NULL, full ? LOAD_WITH_ALTERED_SEARCH_PATH : 0);
}
static void lib_error(char *buf, size_t n) {
    DWORD code = GetLastError();
    DWORD m = FormatMessageA(FORMAT_MESSAGE_FROM_SYSTEM | FORMAT_MESSAGE_IGNORE_INSERTS, NULL, code, 0, buf,
                             (DWORD)n, NULL);
    while (m > 0 && (buf[m - 1] == '\n' || buf[m - 1] == '\r' || buf[m - 1] == ' ')) buf[--m] = '\0';
    if (!m) snprintf(buf, n, "Windows error %lu", (unsigned long)code);
}
/* The folder of this DLL. */
static int self_dir(char *buf, size_t n) {
    HMODULE self;
    if (!GetModuleHandleExA(GET_MODULE_HANDLE_EX_FLAG_FROM_ADDRESS | GET_MODULE_HANDLE_EX_FLAG_UNCHANGED_REFCOUNT,
                            (LPCSTR)(void *)&self_dir, &self))
        return 0;
    DWORD m = GetModuleFileNameA(self, buf, (DWORD)n);
    if (!m || m >= n) return 0;
    char *slash = strrchr(buf, '\\');
    if (slash) *slash = '\0';
    return 1;
}
/* Stay loaded when the host unloads this DLL (see fmi2Instantiate). */
static void pin_self(void) {
    HMODULE self;
    GetModuleHandleExA(GET_MODULE_HANDLE_EX_FLAG_FROM_ADDRESS | GET_MODULE_HANDLE_EX_FLAG_PIN,
                       (LPCSTR)(void *)&pin_self, &self);
}
#else
#define INNER_NAME "pythonfmu_export.so"
typedef void *lib_handle;
typedef pthread_mutex_t shim_lock;
#define SHIM_LOCK_INIT PTHREAD_MUTEX_INITIALIZER
static void lock_take(shim_lock *l) { pthread_mutex_lock(l); }
static void lock_give(shim_lock *l) { pthread_mutex_unlock(l); }
static void *lib_symbol(lib_handle h, const char *name) { return h ? dlsym(h, name) : NULL; }
static lib_handle lib_load(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void lib_error(char *buf, size_t n) { const char *e = dlerror(); snprintf(buf, n, "%s", e ? e : "unknown"); }
/* The folder of this shared object. */
static int self_dir(char *buf, size_t n) {
    Dl_info info;
    if (!dladdr((void *)&self_dir, &info) || !info.dli_fname) return 0;
    char self[PATH_MAX];
    snprintf(self, sizeof self, "%s", info.dli_fname);
    snprintf(buf, n, "%s", dirname(self));
    return 1;
}
/* Stay loaded when the host unloads this library (see fmi2Instantiate). */
static void pin_self(void) {
    Dl_info self;
    if (dladdr((void *)&pin_self, &self) && self.dli_fname)
        dlopen(self.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
}
#endif

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
    int dead;                    /* pythonfmu returned fmi2Fatal: its instance is gone */
    int terminated;              /* fmi2Terminate succeeded (sets refused until fmi2Reset) */
    char name[256];              /* instance name, for messages */
    char *location;              /* resource location the instance was made for (reuse, 6) */
    fmi2ValueReference renew;    /* the Python side's "_renew" variable (0: none) */
    int pooled;                  /* freed by the host, kept for reuse (6): every call but a free is refused */
} Shim;

static fmi2Status renew_inner(Shim *s);

#define POOL_MAX 32
static Shim *g_pool[POOL_MAX];
static int g_pooled = 0;
static shim_lock g_pool_lock = SHIM_LOCK_INIT;
static Shim **g_live = NULL;      /* every instance handed out and not yet released (7) */
static size_t g_n_live = 0, g_cap_live = 0;

/* under g_pool_lock: the index of s among the live instances, or -1 */
static long live_index(const Shim *s) {
    for (size_t i = 0; i < g_n_live; i++)
        if (g_live[i] == s) return (long)i;
    return -1;
}

typedef struct {                 /* an FMU state handed to the host */
    unsigned magic;
    Shim *owner;
    fmi2FMUstate inner;          /* pythonfmu's state (a Python object) */
} ShimState;

static lib_handle g_lib = NULL;

/* pythonfmu 0.7 destroys its interpreter guard twice at exit: a static shared_ptr's
 * destructor (run by exit()) frees it, then the library's destructor function
 * finalizePythonInterpreter (run later by the dynamic loader) decrements the freed object's
 * reference count.  That write corrupts the heap (a C host aborted at exit with "free():
 * corrupted unsorted chunks").  Calling the function from an exit handler registered after
 * the library was loaded runs it first: it empties the pointer and joins the guard's idle
 * thread (no Python call), so both later calls find nothing to destroy.  Registered by every
 * shim that loads the library (each FMU has its own copy), in any host.  On Windows the order
 * is already right (pythonfmu's DllMain calls the function before the library's static
 * destructors run), so nothing is registered there. */
#ifndef _WIN32
static void release_inner_guard(void) {
    void (*fin)(void) = (void (*)(void))lib_symbol(g_lib, "finalizePythonInterpreter");
    if (fin) fin();
}
#endif

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

#define LOAD(name) p_##name = (name##TYPE *)lib_symbol(g_lib, #name); if (!p_##name) return #name;

/* ------------------------------------------------------------------ the Python interpreter */
typedef int (*py_int_fn)(void);
typedef void (*py_initex_fn)(int);
typedef int (*py_run_fn)(const char *);
typedef void *(*py_ptr_fn)(void);
typedef void *(*py_decode_fn)(const char *);
typedef int (*py_setobj_fn)(const char *, void *);
typedef void (*py_decref_fn)(void *);

/* Adds the build environment's site-packages (given in sys._sideslip_fmu_site) after the
 * interpreter's own path entries and before its base site-packages, processing .pth files
 * as a virtual environment would. */
static const char SITE_CODE[] =
    "import os, site, sys\n"
    "dirs = [d for d in sys.__dict__.pop('_sideslip_fmu_site', '').split(os.pathsep) if d and os.path.isdir(d)]\n"
    "known = list(sys.path)\n"
    "pos = next((i for i, p in enumerate(known) if p.endswith(('site-packages', 'dist-packages'))), len(known))\n"
    "for d in dirs:\n"
    "    site.addsitedir(d)\n"
    "new = [p for p in sys.path if p not in known]\n"
    "sys.path[:] = known[:pos] + new + known[pos:]\n"
    "del os, site, dirs, known, pos, new\n";

#ifdef _WIN32
static lib_handle g_python = NULL;       /* python3X.dll */
static void *py_symbol(const char *name) { return lib_symbol(g_python, name); }

/* Try one python3X.dll; on success keep it in g_python and its path in lib. */
static int try_python(const char *path, char *lib, size_t n, char *tried, size_t tn) {
    if (!path || !*path) return 0;
    lib_handle h = lib_load(path);
    if (!h) {
        size_t used = strlen(tried);
        snprintf(tried + used, tn - used, "%s%s", used ? ", " : "", path);
        return 0;
    }
    g_python = h;
    if (!GetModuleFileNameA(h, lib, (DWORD)n)) snprintf(lib, n, "%s", path);
    return 1;
}

/* <InstallPath>\python3X.dll of a Python launcher registry entry (PEP 514), or "". */
static void registry_python(HKEY root, char *out, size_t n) {
    char key[160], dir[MAX_PATH];
    DWORD size = sizeof dir;
    out[0] = '\0';
    snprintf(key, sizeof key, "Software\\Python\\PythonCore\\%s\\InstallPath", SIDESLIP_PY_VERSION);
    if (RegGetValueA(root, key, NULL, RRF_RT_REG_SZ, NULL, dir, &size) == ERROR_SUCCESS && dir[0]) {
        size_t len = strlen(dir);
        snprintf(out, n, "%s%s%s", dir, dir[len - 1] == '\\' ? "" : "\\", SIDESLIP_PY_DLL);
    }
}

/* Find python3X.dll (see the file comment); NULL and lib set on success, else why not. */
static const char *find_python(char *lib, size_t n, char *err, size_t en) {
    char tried[4096] = "", path[MAX_PATH + 32];
    g_python = GetModuleHandleA(SIDESLIP_PY_DLL);           /* a Python host, or started before */
    if (g_python) {
        GetModuleFileNameA(g_python, lib, (DWORD)n);
        return NULL;
    }
    const char *env = getenv("SIDESLIP_FMU_LIBPYTHON");
    if (env && *env) {
        if (try_python(env, lib, n, tried, sizeof tried)) return NULL;
        snprintf(err, en, "no Python interpreter in this process, and SIDESLIP_FMU_LIBPYTHON (%s) cannot be loaded",
                 env);
        return err;
    }
    const char *home = getenv("PYTHONHOME");
    if (home && *home) {
        snprintf(path, sizeof path, "%s\\%s", home, SIDESLIP_PY_DLL);
        if (try_python(path, lib, n, tried, sizeof tried)) return NULL;
    }
    if (try_python(SIDESLIP_PY_DLL, lib, n, tried, sizeof tried)) return NULL;   /* on PATH */
    HKEY roots[2] = {HKEY_CURRENT_USER, HKEY_LOCAL_MACHINE};
    for (int i = 0; i < 2; i++) {
        registry_python(roots[i], path, sizeof path);
        if (try_python(path, lib, n, tried, sizeof tried)) return NULL;
    }
    snprintf(err, en, "no Python %s found (tried %s; no Python launcher registry entry for %s could be loaded); "
             "install Python %s (python.org, 64-bit) and the FMU's requirements (pythonfmu deploy -f X.fmu), "
             "or set SIDESLIP_FMU_LIBPYTHON to the path of %s", SIDESLIP_PY_VERSION, tried, SIDESLIP_PY_VERSION,
             SIDESLIP_PY_VERSION, SIDESLIP_PY_DLL);
    return err;
}

/* python3.dll from the interpreter's folder (pythonfmu's library imports it), and that folder as the
 * interpreter's home unless PYTHONHOME is set. */
static const char *prepare_python(const char *lib, char *err, size_t en, char *home, size_t hn) {
    char dir[MAX_PATH], stable[MAX_PATH + 16];
    snprintf(dir, sizeof dir, "%s", lib);
    char *slash = strrchr(dir, '\\');
    if (slash) *slash = '\0';
    if (!GetModuleHandleA("python3.dll")) {
        snprintf(stable, sizeof stable, "%s\\python3.dll", dir);
        if (!lib_load(stable)) {
            char why[512];
            lib_error(why, sizeof why);
            snprintf(err, en, "found %s but cannot load python3.dll beside it (%s)", lib, why);
            return err;
        }
    }
    home[0] = '\0';
    if (!getenv("PYTHONHOME")) snprintf(home, hn, "%s", dir);
    return NULL;
}

static void set_python_home(const char *home) {
    static wchar_t wide[MAX_PATH];                          /* Python keeps the pointer */
    void (*set_home)(const wchar_t *) = (void (*)(const wchar_t *))py_symbol("Py_SetPythonHome");
    if (set_home && MultiByteToWideChar(CP_ACP, 0, home, -1, wide, MAX_PATH) > 0) set_home(wide);
}
static void clear_python_home(void) {}
#else
static void *py_symbol(const char *name) { return dlsym(RTLD_DEFAULT, name); }

static int same_file(const char *a, const char *b) {
    char ra[PATH_MAX], rb[PATH_MAX];
    return a && b && *a && *b && realpath(a, ra) && realpath(b, rb) && strcmp(ra, rb) == 0;
}

/* Try each ':'-separated candidate; returns the handle and copies the name that loaded. */
static void *open_first(const char *list, char *loaded, size_t n, char *tried, size_t tn) {
    char buf[4096];
    strncpy(buf, list, sizeof buf - 1);
    buf[sizeof buf - 1] = '\0';
    for (char *save = NULL, *c = strtok_r(buf, ":", &save); c; c = strtok_r(NULL, ":", &save)) {
        void *h = dlopen(c, RTLD_NOW | RTLD_GLOBAL);
        if (h) {
            snprintf(loaded, n, "%s", c);
            return h;
        }
        size_t used = strlen(tried);
        snprintf(tried + used, tn - used, "%s%s", used ? ", " : "", c);
    }
    return NULL;
}

/* Find libpython (see the file comment); NULL and lib set on success, else why not. */
static const char *find_python(char *lib, size_t n, char *err, size_t en) {
    py_int_fn is_init = (py_int_fn)dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    if (is_init) {                                          /* a Python host, or started before */
        Dl_info info;
        if (dladdr((void *)is_init, &info) && info.dli_fname) snprintf(lib, n, "%s", info.dli_fname);
        return NULL;
    }
    const char *env = getenv("SIDESLIP_FMU_LIBPYTHON");
    char candidates[4096], tried[4096] = "";
    if (env && *env)
        snprintf(candidates, sizeof candidates, "%s", env);
    else
        snprintf(candidates, sizeof candidates, "%s%s%s", SIDESLIP_BUILD_LIBPYTHON,
                 *SIDESLIP_BUILD_LIBPYTHON ? ":" : "", SIDESLIP_PY_SONAMES);
    if (!open_first(candidates, lib, n, tried, sizeof tried)) {
        snprintf(err, en, "no Python interpreter in this process and no libpython could be loaded "
                 "(tried %s%s); set SIDESLIP_FMU_LIBPYTHON to the path of libpython3.x.so",
                 tried, env && *env ? " from SIDESLIP_FMU_LIBPYTHON" : "");
        return err;
    }
    return NULL;
}

/* The build Python's prefix as home, only for its own library and only if the user set no PYTHONHOME. */
static const char *prepare_python(const char *lib, char *err, size_t en, char *home, size_t hn) {
    (void)err;
    (void)en;
    home[0] = '\0';
    if (!getenv("PYTHONHOME") && *SIDESLIP_BUILD_HOME && same_file(lib, SIDESLIP_BUILD_LIBPYTHON))
        snprintf(home, hn, "%s", SIDESLIP_BUILD_HOME);
    return NULL;
}

static void set_python_home(const char *home) { setenv("PYTHONHOME", home, 1); }
static void clear_python_home(void) { unsetenv("PYTHONHOME"); }   /* read once at start-up */
#endif

/* Make sure an initialised interpreter exists (see the file comment).  NULL on success, else
 * why not.  *note receives what was done (empty inside a Python host). */
static const char *ensure_python(char *err, size_t n, char *note, size_t note_n) {
    note[0] = '\0';
    char lib[4096] = "", home[4096] = "";
    const char *why = find_python(lib, sizeof lib, err, n);
    if (why) return why;
    py_int_fn is_init = (py_int_fn)py_symbol("Py_IsInitialized");
    if (!is_init) {
        snprintf(err, n, "%s is not a Python library (no Py_IsInitialized)", lib);
        return err;
    }
    if (is_init()) return NULL;                    /* a Python host: change nothing */

    py_initex_fn init_ex = (py_initex_fn)py_symbol("Py_InitializeEx");
    py_run_fn run = (py_run_fn)py_symbol("PyRun_SimpleString");
    py_ptr_fn save_thread = (py_ptr_fn)py_symbol("PyEval_SaveThread");
    py_decode_fn decode = (py_decode_fn)py_symbol("PyUnicode_DecodeFSDefault");
    py_setobj_fn sys_set = (py_setobj_fn)py_symbol("PySys_SetObject");
    py_decref_fn decref = (py_decref_fn)py_symbol("Py_DecRef");
    if (!init_ex || !run || !save_thread || !decode || !sys_set || !decref) {
        snprintf(err, n, "%s lacks the Python C API functions the FMU needs", lib);
        return err;
    }
    why = prepare_python(lib, err, n, home, sizeof home);
    if (why) return why;
    if (*home) set_python_home(home);
    init_ex(0);                                    /* 0: leave the host's signal handlers alone */
    if (*home) clear_python_home();                /* keep the host's environment clean */
    const char *env_site = getenv("SIDESLIP_FMU_SITE_PACKAGES");
    const char *site = env_site ? env_site : SIDESLIP_BUILD_SITE;
    void *text = decode(site);
    if (!text || sys_set("_sideslip_fmu_site", text) != 0 || run(SITE_CODE) != 0) {
        if (text) decref(text);
        save_thread();
        snprintf(err, n, "started Python from %s but could not add the site-packages '%s'", lib, site);
        return err;
    }
    decref(text);
    save_thread();                                 /* pythonfmu takes the GIL with PyGILState_Ensure */
    snprintf(note, note_n, "sideslip-fmu: started Python from %s%s%s; site-packages added%s: %s", lib,
             *home ? " with PYTHONHOME=" : "", home, env_site ? " (SIDESLIP_FMU_SITE_PACKAGES)" : "",
             *site ? site : "(none)");
    return NULL;
}

/* Load pythonfmu's library from the directory of this shared object; NULL on success,
 * else a description of what failed. */
static const char *load_inner(char *err, size_t n) {
    if (g_lib) return NULL;
    char dir[4096], path[4200];
    if (!self_dir(dir, sizeof dir)) return "cannot find the folder of the FMU's binary";
#ifdef _WIN32
    snprintf(path, sizeof path, "%s\\%s", dir, INNER_NAME);
#else
    snprintf(path, sizeof path, "%s/%s", dir, INNER_NAME);
#endif
    g_lib = lib_load(path);
    if (!g_lib) {
        char why[1024];
        lib_error(why, sizeof why);
        snprintf(err, n, "cannot load %s: %s", path, why);
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
    if (status > s->worst && status != fmi2Warning) s->worst = status;   /* warnings: logged only (5) */
    (void)instance;                                /* pythonfmu's name may be of a reused instance (6) */
    if (s->host.logger && (status >= fmi2Warning || category_enabled(s, category)))
        s->host.logger(s->host.componentEnvironment, s->name, status, category, message);
}

static fmi2Status worst(Shim *s, fmi2Status st) {
    fmi2Status w = st > s->worst ? st : s->worst;
    if (st == fmi2Fatal) s->dead = 1;
    return w == fmi2Warning ? fmi2OK : w;
}

/* A message made safe as a printf format: hosts pass the text as the format, some format it and
 * some do not, so it must hold no '%'. */
static void no_percent(char *msg) {
    for (char *p = msg; *p; p++) if (*p == '%') *p = '?';
}

/* Log an error of the shim itself to the host (always: errors pass every filter). */
static fmi2Status shim_error(Shim *s, const char *fmt, const char *detail) {
    if (s && s->host.logger) {
        char msg[1024];
        snprintf(msg, sizeof msg, fmt, detail ? detail : "");
        no_percent(msg);
        s->host.logger(s->host.componentEnvironment, s->name, fmi2Error, "logStatusError", msg);
    }
    return fmi2Error;
}

static uint64_t fnv1a(const unsigned char *p, size_t n) {
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; i++) { h ^= p[i]; h *= 1099511628211ull; }
    return h;
}

static void put_u32(unsigned char *p, uint32_t v) { for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (24 - 8 * i)); }
static void put_u64(unsigned char *p, uint64_t v) { for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (56 - 8 * i)); }
static uint32_t get_u32(const unsigned char *p) { uint32_t v = 0; for (int i = 0; i < 4; i++) v = (v << 8) | p[i]; return v; }
static uint64_t get_u64(const unsigned char *p) { uint64_t v = 0; for (int i = 0; i < 8; i++) v = (v << 8) | p[i]; return v; }

/* The state handle if it is a live state of this instance, else NULL (and an error logged). */
static ShimState *own_state(Shim *s, fmi2FMUstate state, const char *call) {
    ShimState *st = (ShimState *)state;
    if (!st) { shim_error(s, "%s: the FMU state is NULL", call); return NULL; }
    if (st->magic != STATE_MAGIC || st->owner != s) {
        shim_error(s, "%s: not an FMU state of this instance (freed, or of another instance)", call);
        return NULL;
    }
    return st;
}

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
    unsigned first = 0, n_in = 0, n_ports = 0, renew = 0;
    int used = 0;
    if (sscanf(text + magic, "%llx:%u:%u:%u:%u:%n", &addr, &first, &n_in, &n_ports, &renew, &used) != 5) goto done;
    s->renew = renew;
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

#define ALIVE(s) if (!(s)) return fmi2Error; \
    if ((s)->pooled) return shim_error((s), "%sthe FMU instance was freed (fmi2FreeInstance)", ""); \
    if ((s)->dead) return shim_error((s), "%sthe FMU instance failed fatally before; only fmi2FreeInstance is possible", "");
#define CALL(expr) Shim *s = (Shim *)c; ALIVE(s) s->worst = fmi2OK; fmi2Status st = (expr); return worst(s, st);

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                                          fmi2Boolean loggingOn) {
    static shim_lock lock = SHIM_LOCK_INIT;
    static char note[8192];
    char err[8192];
    lock_take(&lock);                              /* hosts may instantiate from several threads */
    const char *why = g_lib ? NULL : ensure_python(err, sizeof err, note, sizeof note);
    int first = !g_lib;
    if (!why) why = load_inner(err, sizeof err);
    if (!why && first) {
#ifndef _WIN32
        atexit(release_inner_guard);
#endif
        /* stay loaded when the host unloads this library after fmi2FreeInstance (fmpy does): the
         * instances kept for reuse (6) and the loaded pythonfmu library outlive the unload */
        pin_self();
    }
    lock_give(&lock);
    if (!why && fmuType != fmi2CoSimulation)
        why = "this FMU is for Co-Simulation only; fmi2Instantiate was asked for Model Exchange";
    if (!why && *SIDESLIP_FMU_GUID && (!fmuGUID || strcmp(fmuGUID, SIDESLIP_FMU_GUID) != 0)) {
        snprintf(err, sizeof err, "fmi2Instantiate was given the GUID '%s', this FMU's is '%s' (a modelDescription.xml "
                 "of another FMU or another build?)", fmuGUID ? fmuGUID : "(null)", SIDESLIP_FMU_GUID);
        why = err;
    }
    if (why) {
        if (functions && functions->logger) {
            char msg[8192];
            snprintf(msg, sizeof msg, "%s", why);
            no_percent(msg);
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError", msg);
        }
        return NULL;
    }
    if (!functions) return NULL;
    const char *location = fmuResourceLocation ? fmuResourceLocation : "";
    Shim *s = NULL;
    lock_take(&g_pool_lock);              /* a freed instance of the same location (6) */
    for (int i = g_pooled - 1; i >= 0 && !s; i--)
        if (strcmp(g_pool[i]->location, location) == 0) {
            s = g_pool[i];
            g_pool[i] = g_pool[--g_pooled];
            s->pooled = 0;
        }
    lock_give(&g_pool_lock);
    int reused = s != NULL;
    if (!s) {
        s = (Shim *)calloc(1, sizeof(Shim));
        if (!s) return NULL;
        s->location = strdup(location);
        if (!s->location) { free(s); return NULL; }
    }
    snprintf(s->name, sizeof s->name, "%s", instanceName ? instanceName : "");
    s->host = *functions;
    s->own = *functions;
    s->own.logger = shim_logger;
    s->own.componentEnvironment = s;
    s->logging_on = loggingOn ? 1 : 0;
    s->worst = fmi2OK;
    s->dead = s->terminated = 0;
    if (*note && s->logging_on && functions->logger) {
        no_percent(note);
        functions->logger(functions->componentEnvironment, instanceName, fmi2OK, "logAll", note);
    }
    if (!reused) {
        s->inner = p_fmi2Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation, &s->own, visible,
                                     fmi2True);
        if (!s->inner) {
            free(s->location);
            free(s);
            return NULL;
        }
        lock_take(&g_pool_lock);
        if (g_n_live == g_cap_live) {
            size_t cap = g_cap_live ? 2 * g_cap_live : 16;
            Shim **grown = (Shim **)realloc(g_live, cap * sizeof(Shim *));
            if (grown) { g_live = grown; g_cap_live = cap; }
        }
        if (g_n_live < g_cap_live) g_live[g_n_live++] = s;
        lock_give(&g_pool_lock);
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
    lock_take(&g_pool_lock);                       /* a second free, or a pointer never ours, is a no-op (7) */
    long live = live_index(s);
    int again = live < 0 || s->pooled;
    lock_give(&g_pool_lock);
    if (again) return;
    free_categories(s);
    s->logging_on = 0;
    if (!s->dead) {                                /* keep it for the next fmi2Instantiate (6) */
        s->ports = NULL;
        s->worst = fmi2OK;
        fmi2Status st = renew_inner(s);            /* a fresh Python object; its logs go nowhere now */
        s->host.logger = NULL;
        lock_take(&g_pool_lock);
        int kept = st <= fmi2Warning && s->worst <= fmi2Warning && g_pooled < POOL_MAX;
        if (kept) {
            s->pooled = 1;
            g_pool[g_pooled++] = s;
        }
        lock_give(&g_pool_lock);
        if (kept) return;
    }
    s->host.logger = NULL;
    lock_take(&g_pool_lock);
    live = live_index(s);
    if (live >= 0) g_live[live] = g_live[--g_n_live];
    lock_give(&g_pool_lock);
    p_fmi2FreeInstance(s->inner);
    free(s->kinds);
    free(s->location);
    free(s);
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    Shim *s = (Shim *)c;
    if (!s) return fmi2Error;
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
FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    s->worst = fmi2OK;
    fmi2Status st = worst(s, p_fmi2Terminate(s->inner));
    if (st == fmi2OK) s->terminated = 1;
    return st;
}
/* Make the Python instance new (fmi2Reset, reuse): through its "_renew" variable when it has one,
 * else pythonfmu's reset (which leaks the old Python object). */
static fmi2Status renew_inner(Shim *s) {
    s->ports = NULL;                 /* the instance's port array is re-created */
    fmi2Status st;
    if (s->renew) {
        fmi2String one = "1";
        st = p_fmi2SetString(s->inner, &s->renew, 1, &one);
    } else {
        st = p_fmi2Reset(s->inner);
    }
    if (st <= fmi2Warning) query_layout(s);
    return st;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    s->worst = fmi2OK;
    s->terminated = 0;
    return worst(s, renew_inner(s));
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Shim *s = (Shim *)c;
    ALIVE(s)
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
    ALIVE(s)
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
    ALIVE(s)
    if (s->terminated && all_ports(s, vr, nvr, 'R', 1))
        return shim_error(s, "fmi2SetReal: inputs cannot be set after fmi2Terminate%s", "");
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
    ALIVE(s)
    if (s->terminated && all_ports(s, vr, nvr, 'B', 1))
        return shim_error(s, "fmi2SetBoolean: inputs cannot be set after fmi2Terminate%s", "");
    if (all_ports(s, vr, nvr, 'B', 1)) {
        for (size_t i = 0; i < nvr; i++) s->ports[vr[i] - s->first] = value[i] ? 1.0 : 0.0;
        return fmi2OK;
    }
    s->worst = fmi2OK;
    return worst(s, p_fmi2SetBoolean(s->inner, vr, nvr, value));
}
FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[]) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    for (size_t i = 0; i < nvr && s->renew; i++)
        if (vr && vr[i] == s->renew) return shim_error(s, "fmi2SetString: '_renew' is internal; call fmi2Reset%s", "");
    s->worst = fmi2OK;
    return worst(s, p_fmi2SetString(s->inner, vr, nvr, value));
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    if (!FMUstate) return shim_error(s, "fmi2GetFMUstate: NULL pointer for the state%s", "");
    ShimState *mine = (ShimState *)*FMUstate;
    if (mine && (mine->magic != STATE_MAGIC || mine->owner != s))
        return shim_error(s, "fmi2GetFMUstate: the state to overwrite is not an FMU state of this instance%s", "");
    if (!mine) {
        mine = (ShimState *)calloc(1, sizeof(ShimState));
        if (!mine) return shim_error(s, "fmi2GetFMUstate: out of memory%s", "");
        mine->magic = STATE_MAGIC;
        mine->owner = s;
    }
    fmi2FMUstate old = mine->inner;
    s->worst = fmi2OK;
    fmi2FMUstate fresh = NULL;
    fmi2Status st = worst(s, p_fmi2GetFMUstate(s->inner, &fresh));
    if (st > fmi2Warning || !fresh) {
        if (!*FMUstate) { mine->magic = 0; free(mine); }
        return st > fmi2Warning ? st : shim_error(s, "fmi2GetFMUstate: no state%s", "");
    }
    if (old) p_fmi2FreeFMUstate(s->inner, &old);
    mine->inner = fresh;
    *FMUstate = mine;
    return st;
}
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    ShimState *st = own_state(s, FMUstate, "fmi2SetFMUstate");
    if (!st) return fmi2Error;
    s->worst = fmi2OK;
    fmi2Status r = worst(s, p_fmi2SetFMUstate(s->inner, st->inner));
    if (r <= fmi2Warning) s->terminated = 0;     /* the restored state decides (the Python side checks) */
    return r;
}
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Shim *s = (Shim *)c;
    if (!s) return fmi2Error;
    if (!FMUstate || !*FMUstate) return fmi2OK;   /* freeing nothing is allowed */
    ShimState *st = own_state(s, *FMUstate, "fmi2FreeFMUstate");
    if (!st) return fmi2Error;
    if (!s->dead && st->inner) p_fmi2FreeFMUstate(s->inner, &st->inner);
    st->magic = 0;
    free(st);
    *FMUstate = NULL;
    return fmi2OK;
}
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    ShimState *st = own_state(s, FMUstate, "fmi2SerializedFMUstateSize");
    if (!st) return fmi2Error;
    if (!size) return shim_error(s, "fmi2SerializedFMUstateSize: NULL size pointer%s", "");
    size_t n = 0;
    s->worst = fmi2OK;
    fmi2Status r = worst(s, p_fmi2SerializedFMUstateSize(s->inner, st->inner, &n));
    if (r <= fmi2Warning) *size = n + FRAME_HEAD;
    return r;
}
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                             size_t size) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    ShimState *st = own_state(s, FMUstate, "fmi2SerializeFMUstate");
    if (!st) return fmi2Error;
    size_t n = 0;
    s->worst = fmi2OK;
    fmi2Status r = worst(s, p_fmi2SerializedFMUstateSize(s->inner, st->inner, &n));
    if (r > fmi2Warning) return r;
    if (!serializedState || size != n + FRAME_HEAD) {
        char detail[128];
        snprintf(detail, sizeof detail, "%zu bytes given, %zu needed", size, n + FRAME_HEAD);
        return shim_error(s, "fmi2SerializeFMUstate: wrong buffer size (%s; ask fmi2SerializedFMUstateSize)", detail);
    }
    unsigned char *out = (unsigned char *)serializedState;
    r = worst(s, p_fmi2SerializeFMUstate(s->inner, st->inner, (fmi2Byte *)out + FRAME_HEAD, n));
    if (r > fmi2Warning) return r;
    size_t m = sizeof(FRAME_MAGIC) - 1;
    memcpy(out, FRAME_MAGIC, m);
    put_u32(out + m, FRAME_VERSION);
    put_u64(out + m + 4, (uint64_t)n);
    put_u64(out + m + 12, fnv1a(out + FRAME_HEAD, n));
    return r;
}
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                               fmi2FMUstate *FMUstate) {
    Shim *s = (Shim *)c;
    ALIVE(s)
    if (!FMUstate) return shim_error(s, "fmi2DeSerializeFMUstate: NULL pointer for the state%s", "");
    const unsigned char *in = (const unsigned char *)serializedState;
    size_t m = sizeof(FRAME_MAGIC) - 1;
    if (!in || size < FRAME_HEAD || memcmp(in, FRAME_MAGIC, m) != 0)
        return shim_error(s, "fmi2DeSerializeFMUstate: not a serialised FMU state of sideslip-fmu (wrong header)%s", "");
    if (get_u32(in + m) != FRAME_VERSION)
        return shim_error(s, "fmi2DeSerializeFMUstate: serialised by another version of the format%s", "");
    uint64_t n = get_u64(in + m + 4);
    if (n != size - FRAME_HEAD)
        return shim_error(s, "fmi2DeSerializeFMUstate: length does not match the header (truncated or extended)%s", "");
    if (fnv1a(in + FRAME_HEAD, (size_t)n) != get_u64(in + m + 12))
        return shim_error(s, "fmi2DeSerializeFMUstate: checksum does not match (damaged)%s", "");
    ShimState *st = (ShimState *)calloc(1, sizeof(ShimState));
    if (!st) return shim_error(s, "fmi2DeSerializeFMUstate: out of memory%s", "");
    s->worst = fmi2OK;
    fmi2Status r = worst(s, p_fmi2DeSerializeFMUstate(s->inner, (const fmi2Byte *)in + FRAME_HEAD, (size_t)n,
                                                      &st->inner));
    if (r > fmi2Warning || !st->inner) {
        free(st);
        return r > fmi2Warning ? r : shim_error(s, "fmi2DeSerializeFMUstate: no state%s", "");
    }
    if (*FMUstate) fmi2FreeFMUstate(c, FMUstate);
    st->magic = STATE_MAGIC;
    st->owner = s;
    *FMUstate = st;
    return r;
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
