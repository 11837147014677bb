// relit-synth: synthetic dual-phone capture generator. See docs/synthetic.md.
#include "core/main_wrapper.h"
#include "tools/synth/synth.h"

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::synth::RunSynth); }
