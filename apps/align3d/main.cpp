#include "align3d/cli.hpp"

int main(int argc, char** argv) { return align3d::cli::run(argc, argv); }
