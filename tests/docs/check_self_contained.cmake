# The repository's documentation stands on its own (issue 8, item 10): no Markdown file of the
# repository (README.md, docs/, every OVERVIEW.md and README.md; not the build tree, not data/ which
# holds downloaded npm packages) may point at material a clone does not have:
#   - the design notes or reference material next to the working copy ("../shared", "shared/design.md",
#     "shared/reference"),
#   - absolute paths of the machine it was written on ("/work/", "/home/", "/root/"),
#   - relative Markdown links that leave the repository ([text](../../x)).
# Before the fix docs/ARCHITECTURE.md pointed at ../shared/design.md and docs/FORMATS.md at
# /work/shared/reference/.
#   cmake -DSOURCE_DIR=<repository root> -P check_self_contained.cmake
if(NOT DEFINED SOURCE_DIR)
  message(FATAL_ERROR "check_self_contained.cmake: -DSOURCE_DIR=<repository root> is required")
endif()
get_filename_component(root "${SOURCE_DIR}" REALPATH)
file(GLOB_RECURSE docs RELATIVE "${root}" "${root}/*.md")
set(checked 0)
set(problems "")
foreach(doc ${docs})
  if(doc MATCHES "^(build|data|out|\\.git)/" OR doc MATCHES "(^|/)node_modules/")
    continue()
  endif()
  math(EXPR checked "${checked} + 1")
  # One list element per line (empty lines kept, so line numbers are right); ';', '[' and ']' would
  # confuse CMake's list splitting, so they travel as placeholders.
  file(READ "${root}/${doc}" content)
  string(REPLACE ";" "<SC>" content "${content}")
  string(REPLACE "[" "<LB>" content "${content}")
  string(REPLACE "]" "<RB>" content "${content}")
  string(REPLACE "\n" ";" lines "${content}")
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    string(REPLACE "<SC>" ";" line "${line}")
    # The line as shown in a message (a ';' would split the message list).
    string(REPLACE ";" "," shown "${line}")
    string(REPLACE "<LB>" "[" shown "${shown}")
    string(REPLACE "<RB>" "]" shown "${shown}")
    if(line MATCHES "\\.\\./shared|shared/design\\.md|shared/reference")
      list(APPEND problems "${doc}:${n}: points at the outside design/reference folder: ${shown}")
    endif()
    if(line MATCHES "(^|[^A-Za-z0-9_.~-])/(work|home|root)/")
      list(APPEND problems "${doc}:${n}: absolute path of a particular machine: ${shown}")
    endif()
    # Markdown links ("](target)"): every relative target must stay inside the repository.
    string(REGEX MATCHALL "<RB>\\([^) ]+\\)" links "${line}")
    foreach(link IN LISTS links)
      string(REGEX REPLACE "^<RB>\\(([^) #]*).*\\)$" "\\1" target "${link}")
      if(target STREQUAL "" OR target MATCHES "^[a-z]+:")
        continue()
      endif()
      get_filename_component(dir "${root}/${doc}" DIRECTORY)
      get_filename_component(resolved "${dir}/${target}" ABSOLUTE)
      string(FIND "${resolved}/" "${root}/" at)
      if(NOT at EQUAL 0)
        list(APPEND problems "${doc}:${n}: link '${target}' leaves the repository")
      endif()
    endforeach()
  endforeach()
endforeach()
if(checked LESS 5)
  message(FATAL_ERROR "only ${checked} Markdown files found under ${root}: wrong SOURCE_DIR?")
endif()
if(problems)
  string(REPLACE ";" "\n" text "${problems}")
  message(FATAL_ERROR "documentation that does not stand on its own:\n${text}")
endif()
message("${checked} Markdown files checked: no pointers outside the repository")
