# cmake --install build --prefix P: the library for C++ users.
#   P/lib/libatacom.a                      the engine (projector, envs, safety layers, training)
#   P/include/atacom/*.hpp                 the public headers (self-contained: nothing of src/, train/, kernels/)
#   P/lib/cmake/atacom/                    find_package(atacom) -> target atacom::atacom, atacom_DATA_DIR
#   P/share/atacom/data/                   robot and scene data the envs load
#   P/bin/atacom                           the command-line tool
# A consumer: find_package(atacom REQUIRED) and target_link_libraries(app PRIVATE atacom::atacom)
# (tests/install/ builds one against an install tree in CI).
include(CMakePackageConfigHelpers)

set(ATACOM_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/atacom)
install(TARGETS atacom_lib EXPORT atacomTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/atacom DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev
        FILES_MATCHING PATTERN "*.hpp")
install(EXPORT atacomTargets NAMESPACE atacom:: DESTINATION ${ATACOM_CMAKE_DIR} COMPONENT dev)
configure_package_config_file(${CMAKE_CURRENT_SOURCE_DIR}/cmake/atacomConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/atacomConfig.cmake
                              INSTALL_DESTINATION ${ATACOM_CMAKE_DIR}
                              PATH_VARS CMAKE_INSTALL_INCLUDEDIR CMAKE_INSTALL_DATADIR)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/atacomConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/atacomConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/atacomConfigVersion.cmake
        DESTINATION ${ATACOM_CMAKE_DIR} COMPONENT dev)
install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/data/ DESTINATION ${CMAKE_INSTALL_DATADIR}/atacom/data COMPONENT dev)
install(TARGETS atacom RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
