// Certificates made at test time (OpenSSL): a CA, a server certificate it signs for localhost
// and 127.0.0.1, and an unrelated CA, so TLS tests commit no keys and never expire.
#pragma once

#include <string>

namespace loam::test {

struct TestCertificates {
  std::string ca_cert;        // the CA that signed the server's certificate (PEM)
  std::string server_cert;    // the server's certificate, then the CA's: a chain
  std::string server_key;     // its key (PEM, unencrypted)
  std::string other_ca_cert;  // a CA that signed nothing here
  std::string other_key;      // a key that is not the server certificate's
};

// Writes the files into `dir` (created); aborts the test on an OpenSSL failure.
TestCertificates make_test_certificates(const std::string& dir);

}  // namespace loam::test
