// relit-options-doc: writes (--write) or checks (--check) the options
// reference tables of docs/ from the field tables (options_doc.h).
#include <iostream>
#include <string>

#include "core/main_wrapper.h"
#include "tools/options_doc/options_doc.h"

int main(int argc, char** argv) {
  return relit::RunMain(argc, argv, [](int argc, char** argv) {
    const std::string mode = argc == 3 ? argv[1] : "";
    if (mode != "--write" && mode != "--check") {
      std::cerr << "usage: relit-options-doc --write|--check DOCS_DIR\n";
      return 2;
    }
    const auto differ = relit::options_doc::UpdateDocs(argv[2], mode == "--write");
    for (const std::string& file : differ) {
      std::cout << (mode == "--write" ? "rewrote " : "differs: ") << file << "\n";
    }
    return mode == "--check" && !differ.empty() ? 1 : 0;
  });
}
