/* registry.h — the one list of rendering methods, in the order menus show them. A method is
 * its folder core/methods/<name>/, which defines `const vsd_method vsd_method_<name>`
 * (method.h: its options, capabilities and hooks), and one X(<name>) here. Everything else
 * (the CLI, the daemon's HELLO, the Blender add-on's menus and warnings, the tests that
 * run every method) reads the list and the descriptors through methods.c. */
#ifndef VSD_METHOD_REGISTRY_H
#define VSD_METHOD_REGISTRY_H

#define VSD_METHOD_REGISTRY(X) \
    X(reference)               \
    X(raymarch)                \
    X(shgrid)                  \
    X(constellation)           \
    X(crm)                     \
    X(lbl)

#endif
