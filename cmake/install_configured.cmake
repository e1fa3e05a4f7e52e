# Runs at install time (cmake --install [--prefix P]): the unit and the example config name the
# binary and the model under the prefix actually used. `src` is set by the caller.
foreach(pair "systemd/brakefitd.service|/lib/systemd/system" "systemd/brakefit-sync.service|/lib/systemd/system"
    "config/brakefitd.toml|/etc/brakefit")
  string(REPLACE "|" ";" p "${pair}")
  list(GET p 0 rel)
  list(GET p 1 dir)
  file(READ "${src}/${rel}" text)
  string(REPLACE "/usr/sbin/brakefitd" "${CMAKE_INSTALL_PREFIX}/sbin/brakefitd" text "${text}")
  string(REPLACE "/usr/bin/brakefit " "${CMAKE_INSTALL_PREFIX}/bin/brakefit " text "${text}")
  string(REPLACE "/usr/share/brakefit/" "${CMAKE_INSTALL_PREFIX}/share/brakefit/" text "${text}")
  get_filename_component(name "${rel}" NAME)
  message(STATUS "Installing: $ENV{DESTDIR}${dir}/${name}")
  file(WRITE "$ENV{DESTDIR}${dir}/${name}" "${text}")
endforeach()
