// relit-render: renders an exported relit asset without the workspace.
#include "core/main_wrapper.h"
#include "relight/render_stage.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::relight::RunRender); }
