# Writes OUT: a header with the text of IN as a raw string constant kf::generated::NAME. Run by
# the build (cmake -P) whenever IN changes, so the data stays a plain file and the binary needs
# no path (e.g. src/domain/CostModel.toml).
file(READ ${IN} body)
file(WRITE ${OUT} "#pragma once\n// Generated from ${IN} by cmake/EmbedText.cmake: do not edit.\nnamespace kf::generated {\ninline constexpr const char* ${NAME} = R\"text(${body})text\";\n} // namespace kf::generated\n")
