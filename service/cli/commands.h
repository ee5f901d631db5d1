/* Subcommands of the `vsd` executable. Each takes the arguments after its own name
 * (argv[0] is the subcommand) and returns the process exit status (docs/cli.md). */
#ifndef VSD_CLI_COMMANDS_H
#define VSD_CLI_COMMANDS_H

/* Exit codes shared by all subcommands (documented in README and docs/cli.md). */
enum {
    VSD_EXIT_OK = 0,
    VSD_EXIT_RENDER_FAILED = 1,  /* a frame failed to render or write */
    VSD_EXIT_USAGE = 2,          /* bad command line */
    VSD_EXIT_INPUT = 3,          /* bad input: scene file, VDB, environment map */
    VSD_EXIT_CANCELLED = 130     /* interrupted (SIGINT) */
};

int vsd_cmd_render(int argc, char **argv);
int vsd_cmd_info(int argc, char **argv);
int vsd_cmd_compare(int argc, char **argv);
int vsd_cmd_methods(int argc, char **argv);
int vsd_cmd_export(int argc, char **argv);     /* cmd_export.c: `vsd export pov` */
int vsd_cmd_composite(int argc, char **argv);  /* cmd_composite.c */
int vsd_cmd_farm(int argc, char **argv);       /* cmd_farm.c: `vsd farm slurm|status` */

#endif
