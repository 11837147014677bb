// relit-calib: the calib stage. See docs/calib.md.
#include "calib/calib.h"
#include "core/main_wrapper.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::calib::RunCalib); }
