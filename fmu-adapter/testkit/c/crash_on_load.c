/* A shared library that dies while it is being loaded, like a vendor FMU whose runtime is
 * mapped from a truncated file: its constructor reads a page of an empty file mapped into
 * memory, a genuine bus error (SIGBUS). savme must report it naming the FMU instead of dying
 * with it. Exports nothing else. */
#include <stdio.h>
#include <sys/mman.h>

__attribute__((constructor)) static void die_while_loading(void) {
    FILE *f = tmpfile();
    volatile const char *page;
    if (!f) return;
    page = mmap(NULL, 4096, PROT_READ, MAP_SHARED, fileno(f), 0);
    if (page == MAP_FAILED) return;
    (void)page[0]; /* beyond the end of the (empty) file: SIGBUS */
}

__attribute__((visibility("default"))) const char *fmi2GetVersion(void) { return "2.0"; }
