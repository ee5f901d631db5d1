/* PLACEHOLDER owned by the helper building `vsd export`: replace this whole file. */
#include "commands.h"
#include <stdio.h>

int vsd_cmd_export(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "vsd export: not built yet\n");
    return VSD_EXIT_USAGE;
}
