// The `relit` command line: init, run, status (docs/pipeline.md).
#pragma once

namespace relit::pipeline {

int RunRelit(int argc, char** argv);

}  // namespace relit::pipeline
