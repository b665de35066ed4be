// placeholder: the gap diagnoser lands here (issue 5).
namespace stend::gap {}
