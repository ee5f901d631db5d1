/* PLACEHOLDER owned by the helper building `vsd composite`: replace this whole file. */
#include "commands.h"
#include <stdio.h>

int vsd_cmd_composite(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "vsd composite: not built yet\n");
    return VSD_EXIT_USAGE;
}
