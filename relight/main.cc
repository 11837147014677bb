// relit-relight: the relight stage. See docs/relight.md.
#include "core/main_wrapper.h"
#include "relight/relight_options.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::relight::RunRelight); }
