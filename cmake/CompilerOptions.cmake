# Warnings for the project's own targets only (never exported to consumers).
function(roadpreview_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
endfunction()
