# ostrich_pc.cmake: writes ostrich.pc for the prefix of `cmake --install` (given at install time,
# so this runs as install code). The caller sets OST_PC_IN, OST_PC_OUT, OST_LIBDIR,
# OST_INCLUDEDIR, OST_VERSION, OST_MUJOCO_INCLUDE_DIR, OST_MUJOCO_LIBDIR and OST_SYSTEM_LIBDIRS
# (the directories the linker searches anyway: no rpath is needed there).
set(OST_PREFIX "${CMAKE_INSTALL_PREFIX}")
set(OST_RPATH "-Wl,-rpath,\${libdir} ")
list(FIND OST_SYSTEM_LIBDIRS "${OST_PREFIX}/${OST_LIBDIR}" ost_system)
if(NOT ost_system EQUAL -1)
  set(OST_RPATH "")
endif()
configure_file("${OST_PC_IN}" "${OST_PC_OUT}" @ONLY)
