#include "protocol/result.h"

namespace loam {

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return "invalid argument";
    case ErrorCode::kNotFinite: return "not finite";
    case ErrorCode::kTruncated: return "truncated";
    case ErrorCode::kOversize: return "oversize";
    case ErrorCode::kBadEnum: return "bad enum";
    case ErrorCode::kUnknownType: return "unknown type";
    case ErrorCode::kUnsupported: return "unsupported";
    case ErrorCode::kCorrupt: return "corrupt";
    case ErrorCode::kIo: return "i/o error";
    case ErrorCode::kNotFound: return "not found";
    case ErrorCode::kUnauthorized: return "unauthorized";
    case ErrorCode::kBusy: return "busy (retry later)";
  }
  return "unknown error";
}

std::string Error::describe() const {
  if (field.empty()) return message;
  return field + ": " + message;
}

Error make_error(ErrorCode code, std::string field, std::string message) {
  return Error{code, std::move(field), std::move(message)};
}

}  // namespace loam
