// relit-reconstruct: the reconstruct stage. See docs/reconstruct.md.
#include "core/main_wrapper.h"
#include "reconstruct/reconstruct.h"

int main(int argc, char** argv) {
  return relit::RunMain(argc, argv, relit::reconstruct::RunReconstruct);
}
