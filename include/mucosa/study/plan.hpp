#pragma once
// Perceptual realism study, the protocol of the paper's user study
// ("Photorealistic modeling of tissue reflectance properties", 2006, section
// "Visual assessment"): a calibration pair (category 1 beside category 5),
// Likert ratings 1-5 of single images in random order and in series, and a
// two-alternative forced choice (2AFC) between categories 3, 4 and 5 shown side
// by side, always from different poses.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mucosa::study {

inline constexpr int kMinCategory = 1;  // least realistic
inline constexpr int kMaxCategory = 5;  // real frame (the reference)
inline constexpr int kReferenceCategory = 5;

// One stimulus of the manifest.
struct Image {
    std::string id;              // unique, shown nowhere to the observer
    std::filesystem::path file;  // absolute after readManifest()
    int category = 0;            // 1..5
    std::string patient, pose;   // (patient, pose) identifies a view
    std::string viewKey() const { return patient + "\x1f" + pose; }
};

// Reads images.json: {"images": [{"id", "file", "category", "patient", "pose"}...]}
// (or a bare array). Relative files are resolved against the manifest's folder.
// Throws InputError naming the entry that is wrong.
std::vector<Image> readManifest(const std::filesystem::path& path);

struct PlanOptions {
    int observers = 30;  // number of observer slots planned
    std::uint64_t seed = 1;
    int seriesLength = 15;         // Likert images per series (the paper: 15)
    int likertLimit = 0;           // Likert images per observer; 0 = every image
    int twoafcPerComparison = 10;  // 2AFC pairs per comparison (3v4, 3v5, 4v5); 0 = no 2AFC
};

enum class TrialKind { Calibration, Likert, TwoAfc };

// One screen of the protocol. Indices refer to Plan::images.
struct Trial {
    TrialKind kind = TrialKind::Likert;
    int image = -1;             // Likert
    int left = -1, right = -1;  // calibration (left = category 1) and 2AFC
};

struct ObserverPlan {
    std::vector<Trial> trials;  // calibration, then Likert, then 2AFC
    int likertCount() const;
};

struct Plan {
    std::vector<Image> images;
    PlanOptions options;
    std::vector<ObserverPlan> observers;  // slot i: the observer who opens link i (serve)
    std::string fingerprint;              // hash of options, images (files relative to the plan file) and
                                          // trials; ties an answers database to its plan. makePlan's has
                                          // absolute files; writePlan returns the one the file holds
};

// Builds a reproducible plan (same manifest, options and seed -> same plan on
// every platform: the generator and shuffles are our own, not std::'s).
// Throws InputError saying why a manifest cannot satisfy the protocol.
Plan makePlan(std::vector<Image> images, const PlanOptions& options);

// Atomic; image files are stored relative to the plan's folder and must lie
// inside it (InputError otherwise). Returns the fingerprint written, which is
// what readPlan gives back.
std::string writePlan(const Plan& plan, const std::filesystem::path& path);
Plan readPlan(const std::filesystem::path& path);

const char* trialKindName(TrialKind kind);

}  // namespace mucosa::study
