#pragma once
// The schema text of an "omgidl" MCAP channel: one self-contained IDL text (readers such as
// Foxglove parse it without a preprocessor), made from IDL files that #include each other.
#include <functional>
#include <string>

namespace thermovis::record {

// Returns `file`'s text with every `#include "x"` replaced by the flattened text of x (each file
// once, in include order) and the other preprocessor lines (include guards) removed.
// `load(name)` returns a file's text given its name as written in the #include (and `file` for
// the first). Throws std::runtime_error naming the file for an include cycle or a malformed
// #include line; errors of `load` pass through.
std::string flatten_idl(const std::string& file,
                        const std::function<std::string(const std::string&)>& load);

}  // namespace thermovis::record
