#include "core/main_wrapper.h"
#include "report/report.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::report::RunReport); }
