#include "core/main_wrapper.h"
#include "pipeline/cli.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::pipeline::RunRelit); }
