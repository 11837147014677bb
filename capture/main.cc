// relit-capture: the capture stage. See docs/capture.md.
#include "capture/capture.h"
#include "core/main_wrapper.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::capture::RunCapture); }
