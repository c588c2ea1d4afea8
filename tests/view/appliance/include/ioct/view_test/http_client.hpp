// One HTTP/1.1 request to a local server, with a deadline: what the tests need to ask ioct-view's
// API directly (readiness, a refused change) without a browser.
#pragma once

#include <chrono>
#include <string>

namespace ioct::view_test {

struct HttpReply {
  int status = 0;  // 0: no answer (connection refused, reset or timed out)
  std::string body;
  std::string problem;  // why there was no answer
};

// `bearer` non-empty adds "Authorization: Bearer <bearer>"; a non-empty body is sent as JSON.
HttpReply http_request(unsigned short port, const std::string& method, const std::string& target,
                       const std::string& body = "", const std::string& bearer = "",
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(3000));

// A TCP port on 127.0.0.1 that was free a moment ago (bound to port 0, then released).
unsigned short free_local_port();

}  // namespace ioct::view_test
