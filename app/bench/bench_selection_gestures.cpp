// `handson bench selection --protocol gestures`: the simulated user's corrections
// (app/tools/selection_gestures.h) on every labelled organ of the shared CTs: Dice after each
// gesture (selection_gestures.csv), a summary (selection_gestures.md, also printed) and a chart of
// Dice against gestures per organ (selection_gestures.png).
#include "app/bench/bench_selection_gestures.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app/bench/bench.h"
#include "app/io/nifti_io.h"
#include "app/tools/selection_gestures.h"
#include "sim/base/error.h"
#include "sim/quantized_volume.h"

namespace handson::cli {

namespace {

struct GestureDataset {
  std::string name;
  std::vector<OrganLabel> organs;
};

// The organs and vessels a clinician pinches: every label of the two CTs but the body outline, the
// skeleton (many bones under one label), lungs (air: transparent, a pinch cannot land there), the
// unknown label, and on totalseg-small bones, muscles and structures under 500 voxels (13.5 ml at
// 3 mm: the adrenal glands, the spinal cord, lung lobes cut by the scan).
std::vector<GestureDataset> gestureDatasets() {
  return {{"ircadb1.1",
           {{3, "kidney_left"}, {4, "kidney_right"}, {7, "spleen"}, {8, "liver"}, {9, "artery"}, {10, "portal_vein"}, {11, "venous_system"}, {12, "liver_tumor"}}},
          {"totalseg-small",
           {{1, "spleen"}, {2, "kidney_right"}, {3, "kidney_left"}, {4, "gallbladder"}, {5, "liver"}, {6, "stomach"}, {7, "pancreas"},
            {18, "small_bowel"}, {19, "duodenum"}, {20, "colon"}, {52, "aorta"}, {63, "inferior_vena_cava"}, {64, "portal_vein_and_splenic_vein"}}}};
}

// Dice after `n` gestures (the last step's when the protocol stopped earlier: the selection was the organ).
double diceAfter(const OrganGestures& o, int n) {
  if (o.steps.empty()) return 0.0;
  return o.steps[std::size_t(std::min<int>(n, int(o.steps.size())) - 1)].dice;
}

// The largest fall of Dice one correction caused (0 when none fell).
double worstDrop(const OrganGestures& o) {
  double worst = 0.0;
  for (std::size_t i = 1; i < o.steps.size(); ++i) worst = std::max(worst, o.steps[i - 1].dice - o.steps[i].dice);
  return worst;
}

void writeCsvRows(std::ostream& csv, const OrganGestures& o) {
  for (const GestureStep& s : o.steps)
    csv << o.dataset << "," << o.organ << "," << s.gesture << "," << gestureKindName(s.kind) << "," << std::setprecision(4) << s.dice << "," << s.precision
        << "," << s.recall << "," << s.selected << "," << s.target.x() << " " << s.target.y() << " " << s.target.z() << "," << s.spreadMm << ","
        << s.regionVoxels << "," << s.pinchVoxels << "," << (s.refused ? 1 : 0) << "," << s.milliseconds << "," << s.editMs << "," << s.editFrameMs << "," << s.uploadVoxels << "," << s.liftMs << "\n";
}

// The summary table: Dice after 1, 3, 5 and `last` gestures, the worst single correction, then the
// medians and the lowest.
void writeSummary(const std::vector<OrganGestures>& all, int last, std::ostream& md) {
  const std::vector<int> at{1, 3, 5, last};
  md << "| dataset | organ |";
  for (int n : at) md << " Dice after " << n << " |";
  md << " worst correction |\n|---|---|";
  for (std::size_t i = 0; i <= at.size(); ++i) md << "---|";
  md << "\n" << std::fixed << std::setprecision(3);
  std::vector<std::vector<double>> columns(at.size());
  double worst = 0.0;
  for (const OrganGestures& o : all) {
    md << "| " << o.dataset << " | " << o.organ << " |";
    for (std::size_t i = 0; i < at.size(); ++i) {
      columns[i].push_back(diceAfter(o, at[i]));
      md << " " << columns[i].back() << " |";
    }
    worst = std::max(worst, worstDrop(o));
    md << " " << -worstDrop(o) << " |\n";
  }
  md << "| | **median** |";
  for (const auto& c : columns) md << " **" << median(c) << "** |";
  md << " |\n| | lowest |";
  for (const auto& c : columns) md << " " << (c.empty() ? 0.0 : *std::min_element(c.begin(), c.end())) << " |";
  md << " " << -worst << " |\n";
}

// Dice against gestures, one panel per dataset, one line per organ (gnuplot; skipped without it).
void writeChart(const std::vector<OrganGestures>& all, const std::filesystem::path& out) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    std::cerr << "gnuplot not found: no chart (the CSV has the numbers)\n";
    return;
  }
  const auto data = out / "selection_gestures.dat";
  std::ofstream dat(data);
  std::vector<std::string> datasets;
  for (const OrganGestures& o : all) {
    if (std::find(datasets.begin(), datasets.end(), o.dataset) == datasets.end()) datasets.push_back(o.dataset);
    for (const GestureStep& s : o.steps) dat << s.gesture << " " << s.dice << "\n";
    dat << "\n\n";
  }
  dat.close();
  std::ofstream gp(out / "selection_gestures.gp");
  gp << "set terminal pngcairo size " << 820 * std::max<std::size_t>(datasets.size(), 1) << ",560 font ',11'\nset output '"
     << (out / "selection_gestures.png").string() << "'\nset termoption noenhanced\n"
     << "set multiplot layout 1," << std::max<std::size_t>(datasets.size(), 1)
     << " title 'Dice after each gesture: a first pinch, then corrections at the largest error region (add: united, remove: subtracted)'\n"
     << "set xlabel 'gestures'\nset ylabel 'Dice'\nset yrange [0:1]\nset xrange [0.8:*]\nset xtics 1\nset grid\nset key outside right top font ',9'\n";
  for (const std::string& d : datasets) {
    gp << "set title '" << d << "'\nplot ";
    bool firstLine = true;
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (all[i].dataset != d) continue;
      gp << (firstLine ? "" : ", ") << "'" << data.string() << "' index " << i << " using 1:2 with linespoints title '" << all[i].organ << "'";
      firstLine = false;
    }
    gp << ", 0.9 with lines dt 2 lc rgb '#888888' title 'Dice 0.9'\n";
  }
  gp << "unset multiplot\n";
  gp.close();
  if (std::system(("gnuplot '" + (out / "selection_gestures.gp").string() + "' 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace

int benchSelectionGestures(const std::string& dataDir, const std::filesystem::path& out, const GestureProtocol& protocol) {
  std::filesystem::create_directories(out);
  std::ofstream csv(out / "selection_gestures.csv");
  csv << "dataset,organ,gesture,kind,dice,precision,recall,selected,target,spread_mm,region_voxels,pinch_voxels,refused,ms,edit_ms,edit_frame_ms,upload_voxels,lift_ms\n";
  const int gestures = protocol.gestures;
  std::cerr << "gestures: " << gestures << " an organ, corrections by the " << correctionRuleName(protocol.corrections) << " rule\n";
  std::vector<OrganGestures> all;
  for (const GestureDataset& s : gestureDatasets()) {
    const std::string dir = dataDir + "/" + s.name;
    if (!std::filesystem::exists(dir + "/ct.nii.gz")) {
      std::cerr << "skipping " << s.name << ": " << dir << " not found\n";
      continue;
    }
    const Volume ct = readNifti(dir + "/ct.nii.gz");
    const Volume labels = readNifti(dir + "/labels.nii.gz");
    if (ct.dims() != labels.dims()) throw Error(s.name + ": the label map is not on the CT's grid");
    const QuantizedVolume q = quantizeVolume(ct);
    for (const OrganLabel& organ : s.organs) {
      OrganGestures o = runGestureProtocol(s.name, ct, q, labels, organ, protocol);
      if (o.steps.empty()) continue;
      std::cerr << "  " << s.name << " " << o.organ << ":" << std::fixed << std::setprecision(3);
      for (const GestureStep& st : o.steps) std::cerr << " " << gestureKindName(st.kind)[0] << st.dice;
      std::cerr << "\n";
      writeCsvRows(csv, o);
      all.push_back(std::move(o));
    }
  }
  std::ostringstream md;
  if (all.empty()) md << "No labelled organ was found: nothing measured.\n";
  else writeSummary(all, gestures, md);
  std::ofstream(out / "selection_gestures.md") << md.str();
  std::cout << "Dice after gestures (" << (out / "selection_gestures.csv").string() << "):\n" << md.str();
  writeChart(all, out);
  return 0;
}

}  // namespace handson::cli
