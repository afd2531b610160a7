// placeholder
namespace imt {}
