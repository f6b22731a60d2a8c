// Truncation check for JPEG and PNG files by their end markers, read without decoding.
#include "hazardforge/image_file.hpp"

#include <algorithm>
#include <fstream>
#include <string_view>

#include "hazardforge/error.hpp"

namespace hf {

namespace {

// Writers may pad after the end marker; a cut file has no marker anywhere near its end.
constexpr std::streamoff kTail = 1024;

}  // namespace

void require_complete_image(const std::filesystem::path& file, const std::string& what) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return;  // unreadable files are the decoder's to report
  char head[8] = {};
  in.read(head, sizeof head);
  const std::string_view h(head, static_cast<size_t>(in.gcount()));
  const bool jpeg = h.size() >= 3 && h.substr(0, 3) == std::string_view("\xFF\xD8\xFF", 3);
  const bool png = h.size() == 8 && h == std::string_view("\x89PNG\r\n\x1A\n", 8);
  if (!jpeg && !png) return;
  in.clear();
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff start = std::max<std::streamoff>(0, size - kTail);
  std::string tail(static_cast<size_t>(size - start), '\0');
  in.seekg(start);
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  if (jpeg && tail.find(std::string_view("\xFF\xD9", 2)) == std::string::npos)
    throw Error(what +
                " is truncated: the JPEG has no end-of-image marker (the decoder would fill the rest "
                "with grey)");
  if (png && tail.find("IEND") == std::string::npos)
    throw Error(what + " is truncated: the PNG has no IEND chunk");
}

}  // namespace hf
