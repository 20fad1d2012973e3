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

namespace thermovis::record {

// `idl` with every integer constant's value and every array bound written as a literal:
// `const unsigned long N = W * H;` becomes `= 2073600;` and `octet a[1920 * 1080]` becomes
// `octet a[2073600]`. Foxglove's IDL parser takes literals only there. Comments are kept;
// expressions use literals, integer constants declared before and + - * / % ( ). Throws
// std::runtime_error naming the expression when one uses an unknown name or does not parse.
std::string fold_constant_expressions(const std::string& idl);

}  // namespace thermovis::record
