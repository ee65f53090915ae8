// `ugvr compare A B`: how far apart two rendered images are (RMS, max, PSNR over RGB; SSIM of the luminance), the
// figures the engines' accuracy is quoted in (image.h defines them). PNG or PFM, any mix.
#include <cstdio>

#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/json_file.h"
#include "ugvr/render/image.h"

namespace ugvr::cli {
namespace {

Image read_any(const std::string& path) {
  const std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  if (ext == ".pfm") return read_pfm(path);
  if (ext == ".png") return read_png(path);
  fail_in(path, "expected a .png or .pfm image");
}

}  // namespace

void register_compare(CLI::App& app) {
  struct Options {
    std::string a, b, json;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("compare", "Compare two images: RMS, max difference, PSNR (RGB) and SSIM");
  cmd->add_option("A", o->a, "Image (.png or .pfm)")->required()->type_name("IMAGE");
  cmd->add_option("B", o->b, "Image of the same size")->required()->type_name("IMAGE");
  cmd->add_option("--json", o->json, "Also write the figures as JSON")->type_name("FILE");
  cmd->callback([o] {
    const Image a = read_any(o->a), b = read_any(o->b);
    if (a.width != b.width || a.height != b.height)
      fail_in(o->b, "is " + std::to_string(b.width) + "x" + std::to_string(b.height) + ", " + o->a + " is " +
                        std::to_string(a.width) + "x" + std::to_string(a.height));
    const ImageDifference d = compare_images(a, b);
    const double s = ssim(a, b);
    std::printf("rms %.6g  max %.6g  psnr %.2f dB  ssim %.5f\n", d.rms, d.max_abs, d.psnr_db, s);
    if (!o->json.empty())
      write_json_file(
          o->json,
          {{"a", o->a}, {"b", o->b}, {"rms", d.rms}, {"max_abs", d.max_abs}, {"psnr_db", d.psnr_db}, {"ssim", s}});
  });
}

}  // namespace ugvr::cli
