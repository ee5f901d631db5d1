/* PLACEHOLDER owned by the helper building `vsd farm`: replace this whole file. */
#include "commands.h"
#include <stdio.h>

int vsd_cmd_farm(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "vsd farm: not built yet\n");
    return VSD_EXIT_USAGE;
}
