# The libraries a fuzz target links: haha_format, plus those named on its "// links: ..."
# line (tests/fuzz/targets/dataset_json.cpp says "// links: haha_data").
function(haha_fuzz_links source out)
  file(STRINGS ${source} lines REGEX "^// links: ")
  set(libs haha_format)
  foreach(line ${lines})
    string(REGEX REPLACE "^// links: " "" names "${line}")
    separate_arguments(names)
    list(APPEND libs ${names})
  endforeach()
  set(${out} ${libs} PARENT_SCOPE)
endfunction()
