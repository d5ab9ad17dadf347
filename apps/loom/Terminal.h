#pragma once
// Text from inputs (file names, scene values, error messages quoting them) on its way to a terminal:
// control and invisible format characters are escaped (HiddenText.h), so an input cannot move the cursor,
// clear the screen, forge lines of output or reorder what the terminal shows.
#include <string>

#include "loom/cloth/HiddenText.h"

namespace loom::app {

inline std::string printable(const std::string& s) { return loom::show_hidden(s); }

}  // namespace loom::app
