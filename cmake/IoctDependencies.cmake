# "May depend on", enforced: each folder's README says which of the project's libraries a target
# may use; ioct_may_depend_on() writes that list into the build, and the configure step fails when
# the target links (directly, PUBLIC, PRIVATE or INTERFACE) a project library outside it. External
# libraries (Boost, FFTW, CUDA, ...) are not checked here: the folder READMEs name them.
#
#   ioct_may_depend_on(ioct_rt_core ioct::shm ioct::hal ioct::common)
#
# The check runs once the whole project is configured (cmake_language(DEFER)), so links added
# later in the file, or conditionally, are seen too. Project libraries are the targets named
# ioct_* and their ioct:: aliases.

function(_ioct_canonical out name)
  if(TARGET "${name}")
    get_target_property(aliased "${name}" ALIASED_TARGET)
    if(aliased)
      set(name "${aliased}")
    endif()
  endif()
  set(${out} "${name}" PARENT_SCOPE)
endfunction()

function(_ioct_check_links target)
  set(allowed "")
  foreach(a IN LISTS ARGN)
    _ioct_canonical(canonical "${a}")
    list(APPEND allowed "${canonical}")
  endforeach()
  get_target_property(direct "${target}" LINK_LIBRARIES)
  get_target_property(interface "${target}" INTERFACE_LINK_LIBRARIES)
  set(links "")
  foreach(list_name IN ITEMS direct interface)
    if(${list_name})
      list(APPEND links ${${list_name}})
    endif()
  endforeach()
  foreach(link IN LISTS links)
    # $<LINK_ONLY:x> (a static library's private links) and other generator expressions.
    string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" link "${link}")
    _ioct_canonical(canonical "${link}")
    if(NOT canonical MATCHES "^ioct")
      continue()
    endif()
    if(NOT canonical IN_LIST allowed)
      message(FATAL_ERROR
        "${target} links ${link}, which is not among the libraries it may depend on "
        "(${ARGN}); see its folder's README and docs/ARCHITECTURE.md")
    endif()
  endforeach()
endfunction()

function(ioct_may_depend_on target)
  if(NOT TARGET "${target}")
    message(FATAL_ERROR "ioct_may_depend_on: no target ${target}")
  endif()
  # A deferred call reads variables when it runs: the values are written into it now.
  set(arguments "[[${target}]]")
  foreach(a IN LISTS ARGN)
    string(APPEND arguments " [[${a}]]")
  endforeach()
  cmake_language(EVAL CODE
    "cmake_language(DEFER DIRECTORY [[${CMAKE_SOURCE_DIR}]] CALL _ioct_check_links ${arguments})")
endfunction()
