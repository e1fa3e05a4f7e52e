#pragma once
// How the fleet commands reach the central server: the URL never carries the password (it would
// show in `ps` and the journal); it comes from a file (a systemd credential) or the environment,
// and TLS is required with the server's certificate checked against its name (verify-full).
#include <map>
#include <string>

namespace brakefit::cli {

/// A password file's first line (trailing newline dropped); ExitError 66 when it cannot be read.
std::string read_password_file(const std::string& path);

/// libpq settings for the URL: sslmode=verify-full, connect_timeout, application_name, and the
/// password from password_file (trailing newline dropped), else $BRAKEFIT_FLEET_PASSWORD (else
/// libpq's own PGPASSWORD/PGPASSFILE). ExitError 64 when the URL carries a password, 66 when the
/// file cannot be read.
std::map<std::string, std::string> fleet_settings(const std::string& url,
                                                  const std::string& password_file,
                                                  const std::string& application_name);

}  // namespace brakefit::cli
