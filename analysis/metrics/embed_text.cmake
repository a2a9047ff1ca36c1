# Writes OUTPUT, a C++ file defining `extern const char* const SYMBOL` in namespace
# plumage::analysis::embedded with the text of INPUT, so that the library carries its data
# tables (analysis/metrics/data/) and needs no file at run time. Rewrites OUTPUT only when it changes.
#   cmake -DINPUT=... -DOUTPUT=... -DSYMBOL=... -P embed_text.cmake
file(READ "${INPUT}" text)
string(FIND "${text}" ")plumage_data\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${INPUT}: holds the raw-string delimiter )plumage_data\" and cannot be embedded")
endif()
file(WRITE "${OUTPUT}.new"
     "// Generated from ${INPUT} by analysis/metrics/embed_text.cmake; do not edit.\n"
     "namespace plumage::analysis::embedded {\n"
     "extern const char* const ${SYMBOL};\n"
     "const char* const ${SYMBOL} = R\"plumage_data(${text})plumage_data\";\n"
     "}  // namespace plumage::analysis::embedded\n")
file(COPY_FILE "${OUTPUT}.new" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.new")
