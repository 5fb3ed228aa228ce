/* A shared library that dies while it is being loaded (SIGBUS in its constructor), like a
 * vendor FMU built against a missing licence server or a broken runtime: savme must report it
 * naming the FMU instead of dying with it. Exports nothing else. */
#include <signal.h>

__attribute__((constructor)) static void die_while_loading(void) { raise(SIGBUS); }

__attribute__((visibility("default"))) const char *fmi2GetVersion(void) { return "2.0"; }
