# Install and export so that another project can `find_package(printtwin)`.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS printtwin EXPORT printtwinTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS printtwin_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/printtwin DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES ${PROJECT_BINARY_DIR}/include/printtwin/version.hpp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/printtwin)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/samples/printers OPTIONAL
        DESTINATION ${CMAKE_INSTALL_DATADIR}/printtwin)
install(EXPORT printtwinTargets NAMESPACE printtwin::
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/printtwin)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/printtwinConfig.cmake.in
  ${PROJECT_BINARY_DIR}/printtwinConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/printtwin)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/printtwinConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/printtwinConfig.cmake
              ${PROJECT_BINARY_DIR}/printtwinConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/printtwin)
