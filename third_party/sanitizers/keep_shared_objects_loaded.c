/* Linked into executables only in sanitizer builds (PENUMBRA_SANITIZE).
 * Mesa's drivers are dlclose()d before LeakSanitizer symbolises its report, which then shows a
 * spurious leak from an "<unknown module>" with no stack. Keeping shared objects loaded removes
 * it; real leaks in our code are still reported. */
int dlclose(void* handle) {
    (void)handle;
    return 0;
}
