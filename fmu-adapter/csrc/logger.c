/* The FMI 2.0 logger savme hands to an FMU (fmi2CallbackLogger is C-variadic, which stable Rust
 * cannot define): formats the message printf-style and passes the text to savme_fmu_log. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

extern void savme_fmu_log(void *env, const char *instance, int status, const char *category,
                          const char *message);

void savme_fmu_logger(void *env, const char *instance, int status, const char *category,
                      const char *message, ...) {
    char small[1024];
    char *text = small;
    va_list ap;
    int n;
    if (!message) message = "";
    va_start(ap, message);
    n = vsnprintf(small, sizeof small, message, ap);
    va_end(ap);
    if (n < 0) {
        savme_fmu_log(env, instance, status, category, message);
        return;
    }
    if ((size_t)n >= sizeof small) {
        char *big = malloc((size_t)n + 1);
        if (big) {
            va_start(ap, message);
            vsnprintf(big, (size_t)n + 1, message, ap);
            va_end(ap);
            text = big;
        }
    }
    savme_fmu_log(env, instance, status, category, text);
    if (text != small) free(text);
}
