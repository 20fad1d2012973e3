// thermovis: the command-line tool. Every subcommand lives in its own cmd_*.cpp.
#include "command.hpp"

int main(int argc, char** argv) { return thermovis::cli::run_main(argc, argv); }
