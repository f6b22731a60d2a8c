# hazardforge_add_plugin(<name> SOURCES <files...> [ENTRY <file>] [LIBRARIES <libs...>] [NO_INSTALL])
#
# Builds lib<name>.so as a MODULE with hidden visibility: only the HAZARDFORGE_PLUGIN entry symbol is exported.
# With ENTRY, SOURCES go into a static library <name>_impl (linkable by tests) and ENTRY holds the
# HAZARDFORGE_PLUGIN block; without it, all SOURCES make the module.
function(hazardforge_add_plugin name)
  cmake_parse_arguments(ARG "NO_INSTALL" "ENTRY" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT ARG_SOURCES AND NOT ARG_ENTRY)
    message(FATAL_ERROR "hazardforge_add_plugin(${name}): no SOURCES")
  endif()
  set(sdk_target HazardForge::sdk)
  if(ARG_ENTRY)
    add_library(${name}_impl STATIC ${ARG_SOURCES})
    target_link_libraries(${name}_impl PUBLIC ${sdk_target} ${ARG_LIBRARIES})
    target_include_directories(${name}_impl PUBLIC ${CMAKE_CURRENT_SOURCE_DIR})
    set_target_properties(${name}_impl PROPERTIES POSITION_INDEPENDENT_CODE ON
      CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
    add_library(${name} MODULE ${ARG_ENTRY})
    target_link_libraries(${name} PRIVATE ${name}_impl)
  else()
    add_library(${name} MODULE ${ARG_SOURCES})
    target_link_libraries(${name} PRIVATE ${sdk_target} ${ARG_LIBRARIES})
  endif()
  set_target_properties(${name} PROPERTIES PREFIX "lib" CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  # Every symbol resolved at link time, so a missing library is a build error, not a dlopen error. Clang's
  # sanitizers link their runtime into executables only: a sanitized build sets HAZARDFORGE_ALLOW_UNDEFINED.
  if(NOT HAZARDFORGE_ALLOW_UNDEFINED)
    target_link_options(${name} PRIVATE "LINKER:--no-undefined")
  endif()
  if(HAZARDFORGE_PLUGIN_OUTPUT_DIR)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${HAZARDFORGE_PLUGIN_OUTPUT_DIR})
  endif()
  if(HAZARDFORGE_PLUGIN_INSTALL_DIR AND NOT ARG_NO_INSTALL)
    install(TARGETS ${name} LIBRARY DESTINATION ${HAZARDFORGE_PLUGIN_INSTALL_DIR})
  endif()
endfunction()
