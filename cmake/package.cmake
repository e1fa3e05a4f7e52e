# Man pages and the Debian package (`cpack -G DEB` in the build tree).
find_package(Python3 REQUIRED COMPONENTS Interpreter)
find_program(BRAKEFIT_HELP2MAN help2man)
if(NOT BRAKEFIT_HELP2MAN)
  message(FATAL_ERROR "help2man not found (Debian package help2man; scripts/deps.sh installs it)")
endif()

# brakefit(1), brakefit-sync(1) and brakefitd(8) from their help text (cmake/manpage.py) and docs/man/TARGET.h2m.
function(brakefit_manpage target section summary)
  set(out ${PROJECT_BINARY_DIR}/man/${target}.${section}.gz)
  add_custom_command(OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/man
    COMMAND ${CMAKE_COMMAND} -E env PATH=/usr/bin:/bin ${Python3_EXECUTABLE}
            ${PROJECT_SOURCE_DIR}/cmake/manpage.py $<TARGET_FILE:${target}> ${section} "${summary}"
            ${PROJECT_SOURCE_DIR}/docs/man/${target}.h2m ${PROJECT_SOURCE_DIR}/README.md ${out}
    DEPENDS ${target} ${PROJECT_SOURCE_DIR}/cmake/manpage.py
            ${PROJECT_SOURCE_DIR}/docs/man/${target}.h2m ${PROJECT_SOURCE_DIR}/README.md
    COMMENT "Man page ${target}(${section})" VERBATIM)
  add_custom_target(man_${target} ALL DEPENDS ${out})
  install(FILES ${out} DESTINATION ${CMAKE_INSTALL_MANDIR}/man${section})
endfunction()
brakefit_manpage(brakefit 1 "brake-slip identification for roller brake testers")
brakefit_manpage(brakefitd 8 "roller brake tester data acquisition daemon")
brakefit_manpage(brakefit-sync 1 "ship a station's brake events to the central PostgreSQL")

# Debian's documentation: copyright, and the changelog compressed as policy wants (gzip -9n).
set(deb ${PROJECT_SOURCE_DIR}/packaging/deb)
file(STRINGS ${deb}/changelog top LIMIT_COUNT 1)
if(NOT top MATCHES "^brakefit \\(${PROJECT_VERSION}\\) ")
  message(FATAL_ERROR "packaging/deb/changelog: the newest entry is '${top}', the project is "
                      "${PROJECT_VERSION}: add an entry for it")
endif()
add_custom_command(OUTPUT ${PROJECT_BINARY_DIR}/changelog.gz
  COMMAND sh -c "gzip -9nc '${deb}/changelog' > '${PROJECT_BINARY_DIR}/changelog.gz'"
  DEPENDS ${deb}/changelog VERBATIM)
add_custom_target(deb_changelog ALL DEPENDS ${PROJECT_BINARY_DIR}/changelog.gz)
install(FILES ${deb}/copyright ${PROJECT_BINARY_DIR}/changelog.gz DESTINATION ${CMAKE_INSTALL_DOCDIR})

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME brakefit)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "brakefit maintainers <brakefit@example.org>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "roller brake tester data acquisition and Magic Formula fitting")
# The summary is the synopsis line; CPack indents these lines and turns the empty one into " .".
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION
"brakefit reads a vehicle inspection roller brake tester (roller and wheel
encoders on GPIO, brake-line pressure on Modbus RTU, or a CAN bench), cuts
the stream into brake events and identifies the Pacejka-96 (Magic Formula)
parameters B, C, D and E of each by a self-organizing map, an MLP, least
squares and a hybrid of them.

The brakefitd service stores every event in SQLite and publishes it on
Modbus TCP; the brakefit command replays recorded tests, compares roller
and flat-ground braking and diagnoses where the model and the measurement
disagree.")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # brakefit_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${deb}/conffiles ${deb}/postinst ${deb}/prerm ${deb}/postrm)
set(CPACK_STRIP_FILES ON)
# Absolute destinations (/lib/systemd, /lib/udev, /etc) go through DESTDIR under /usr's root.
set(CPACK_SET_DESTDIR ON)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)
include(CPack)
